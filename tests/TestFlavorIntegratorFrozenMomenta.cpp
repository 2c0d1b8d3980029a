// The artificial FLAVOR's frozen drift where the frozen set turns: the normal momenta of the frozen distances are
// kept, the motion on the constraint manifold feels their kinetic energy (1/2) mu^T B(q) mu, and a Langevin run
// samples the exact distribution of a torsion between frozen angles.

#include "FlavorIntegrator.h"
#include "FrozenStage.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/PeriodicTorsionForce.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorFrozenMomenta : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorFrozenMomenta);

namespace {

/**
 * Neopentane, C(CH3)4, with every bond and every angle stiff: 16 bonds and the 1-3 distances of 30 angles on 17 atoms.
 * Each carbon has four neighbours, whose six 1-3 distances and four bonds are one more than the nine degrees of
 * freedom they fix: the full set is redundant.  The positions are slightly off the ideal tetrahedra.
 */
System* neopentane(vector<Vec3>& positions, vector<std::array<int, 3>>& angles) {
    System* system = new System();
    const double s = 1 / std::sqrt(3.0);
    const Vec3 directions[4] = {Vec3(s, s, s), Vec3(s, -s, -s), Vec3(-s, s, -s), Vec3(-s, -s, s)};
    std::mt19937 random(3);
    std::uniform_real_distribution<double> jitter(-0.003, 0.003);
    auto add = [&](double mass, Vec3 position) {
        positions.push_back(position + Vec3(jitter(random), jitter(random), jitter(random)));
        return system->addParticle(mass);
    };
    HarmonicBondForce* bonds = new HarmonicBondForce();
    HarmonicAngleForce* angleForce = new HarmonicAngleForce();
    const int centre = add(12.0, Vec3());
    vector<int> methyls;
    for (int i = 0; i < 4; ++i) {
        const int carbon = add(12.0, directions[i] * 0.153);
        bonds->addBond(centre, carbon, 0.153, 2.5e5);
        vector<int> hydrogens;
        for (int j = 0; j < 4; ++j)
            if (j != i) {
                hydrogens.push_back(add(1.0, directions[i] * 0.153 - directions[j] * 0.109));
                bonds->addBond(carbon, hydrogens.back(), 0.109, 2.8e5);
                angles.push_back({centre, carbon, hydrogens.back()});
            }
        for (int a = 0; a < 3; ++a)
            for (int b = a + 1; b < 3; ++b)
                angles.push_back({hydrogens[a], carbon, hydrogens[b]});
        methyls.push_back(carbon);
    }
    for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
            angles.push_back({methyls[a], centre, methyls[b]});
    for (const std::array<int, 3>& angle : angles)
        angleForce->addAngle(angle[0], angle[1], angle[2], 1.911, 400.0);
    bonds->setForceGroup(StiffGroup);
    angleForce->setForceGroup(StiffGroup);
    system->addForce(bonds);
    system->addForce(angleForce);
    return system;
}

/**
 * Butane-like chains 0-1-2-3 (united atoms), copies of them 1 nm apart without interactions: the bonds 0-1 and 2-3
 * and both angles stiff, the middle bond a System constraint, and a soft torsion k (1 + cos phi) in SoftGroup.  The
 * torsion turns the angle between the 1-3 distances 0-2 and 1-3, so B = J M^-1 J^T changes as a chain turns.
 */
System* butane(double torsionK, int copies = 1) {
    System* system = new System();
    HarmonicBondForce* bonds = new HarmonicBondForce();
    HarmonicAngleForce* angles = new HarmonicAngleForce();
    PeriodicTorsionForce* torsion = new PeriodicTorsionForce();
    for (int copy = 0; copy < copies; ++copy) {
        const int first = system->getNumParticles();
        for (double mass : {15.0, 14.0, 14.0, 15.0})
            system->addParticle(mass);
        bonds->addBond(first, first + 1, 0.153, 2.5e5);
        bonds->addBond(first + 2, first + 3, 0.153, 2.5e5);
        angles->addAngle(first, first + 1, first + 2, 1.955, 500.0);
        angles->addAngle(first + 1, first + 2, first + 3, 1.955, 500.0);
        torsion->addTorsion(first, first + 1, first + 2, first + 3, 1, 0.0, torsionK);
        system->addConstraint(first + 1, first + 2, 0.153);
    }
    bonds->setForceGroup(StiffGroup);
    angles->setForceGroup(StiffGroup);
    torsion->setForceGroup(SoftGroup);
    system->addForce(bonds);
    system->addForce(angles);
    system->addForce(torsion);
    return system;
}

/** A gauche-like start of each chain. */
vector<Vec3> butanePositions(int copies = 1) {
    const Vec3 chain[4] = {Vec3(-0.05, 0.143, 0.01), Vec3(0, 0, 0), Vec3(0.153, 0, 0), Vec3(0.21, 0.09, 0.11)};
    vector<Vec3> positions;
    for (int copy = 0; copy < copies; ++copy)
        for (const Vec3& x : chain)
            positions.push_back(x + Vec3(copy, 0, 0));
    return positions;
}

/**
 * A chain 0-1-2-3 of carbons with its bonds and angles stiff, the angle 0-1-2 nearly straight (172 degrees): the 1-3
 * distance 0-2 is nearly dependent on the bonds 0-1 and 1-2 (B's smallest pivot about 1.4 % of its diagonal), the
 * case where the normal momenta are ill conditioned.
 */
System* nearlyLinearChain(vector<Vec3>& positions) {
    System* system = new System();
    HarmonicBondForce* bonds = new HarmonicBondForce();
    HarmonicAngleForce* angles = new HarmonicAngleForce();
    const double bend = 8 * M_PI / 180, length = 0.15;
    positions = {Vec3(0, 0, 0), Vec3(length, 0, 0), Vec3(length * (1 + std::cos(bend)), length * std::sin(bend), 0)};
    positions.push_back(positions[2] + Vec3(0.03, -0.1, 0.1) * (length / std::sqrt(0.0209)));
    for (int i = 0; i < 4; ++i)
        system->addParticle(12.0);
    for (int i = 0; i < 3; ++i)
        bonds->addBond(i, i + 1, length, 3e5);
    angles->addAngle(0, 1, 2, M_PI - bend, 400.0);
    angles->addAngle(1, 2, 3, 1.92, 400.0);
    bonds->setForceGroup(StiffGroup);
    angles->setForceGroup(StiffGroup);
    system->addForce(bonds);
    system->addForce(angles);
    return system;
}

/** The dihedral angle of the chain whose atoms start at first. */
double dihedral(const vector<Vec3>& q, int first = 0) {
    const Vec3* x = q.data() + first;
    const Vec3 b0 = x[0] - x[1], b1 = (x[2] - x[1]) / std::sqrt((x[2] - x[1]).dot(x[2] - x[1])), b2 = x[3] - x[2];
    const Vec3 v = b0 - b1 * b0.dot(b1), w = b2 - b1 * b2.dot(b1);
    return std::atan2(b1.cross(v).dot(w), v.dot(w));
}

/**
 * mu = B^-1 rdot for the constraints pairs at (q, v), dense: the normal momenta (B with unit directions, rdot the
 * rates along them).
 */
Eigen::VectorXd normalMomenta(const vector<std::pair<int, int>>& pairs, const System& system, const vector<Vec3>& q,
                              const vector<Vec3>& v) {
    const int m = (int)pairs.size();
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(m, m);
    Eigen::VectorXd rates(m);
    for (int c = 0; c < m; ++c) {
        rates[c] = rate(q, v, pairs[c].first, pairs[c].second);
        const Vec3 uc = (q[pairs[c].first] - q[pairs[c].second]) / distance(q, pairs[c].first, pairs[c].second);
        for (int d = 0; d < m; ++d) {
            const Vec3 ud = (q[pairs[d].first] - q[pairs[d].second]) / distance(q, pairs[d].first, pairs[d].second);
            const int ends[2][2] = {{pairs[c].first, pairs[c].second}, {pairs[d].first, pairs[d].second}};
            for (int e = 0; e < 2; ++e)
                for (int f = 0; f < 2; ++f)
                    if (ends[0][e] == ends[1][f])
                        b(c, d) += (e == f ? 1.0 : -1.0) * uc.dot(ud) / system.getParticleMass(ends[0][e]);
        }
    }
    return b.ldlt().solve(rates);
}

double kineticEnergy(const System& system, const vector<Vec3>& v) {
    double energy = 0.0;
    for (int i = 0; i < system.getNumParticles(); ++i)
        energy += 0.5 * system.getParticleMass(i) * v[i].dot(v[i]);
    return energy;
}

} // namespace

TEST_P(FlavorFrozenMomenta, FrozenStageKeepsTheNormalMomentaOfTheFrozenDistances) {
    // Over the frozen drift the frozen distances hold and their normal momenta, the entries of mu = B^-1 (0, rdot)
    // (B over the System constraint and the four frozen distances, computed here), stay what they were; the System
    // constraint keeps rate 0.  The chain turns, so B changes and the rates themselves do not come back.
    // The state before the drift is the integrator's own after a step with delta = tau (the microstep alone), where
    // the System constraint is held as the integrator holds it.
    const double delta = 0.004, tau = 1e-4, tolerance = 1e-12;
    const vector<Vec3> v0 = {Vec3(0.4, -0.9, 1.2), Vec3(-0.3, 0.2, -0.5), Vec3(-0.3, 0.6, 0.4), Vec3(-0.8, -0.4, 1.5)};
    std::unique_ptr<System> microSystem(butane(0.0)), system(butane(0.0));
    FrozenStage stage =
        runFrozenStage(*microSystem, butanePositions(), v0, tau, tau, tolerance, platform(), properties());
    stage.q1 = stage.q2;
    stage.v1 = stage.v2;
    const FrozenStage full =
        runFrozenStage(*system, butanePositions(), v0, delta, tau, tolerance, platform(), properties());
    stage.q2 = full.q2;
    stage.v2 = full.v2;
    const vector<std::pair<int, int>> pairs = {{1, 2}, {0, 1}, {2, 3}, {0, 2}, {1, 3}};
    // OpenCL holds the System constraint of the microstep with its own algorithm, to about 1e-9 nm (measured 1.1e-9).
    for (const std::pair<int, int>& pair : pairs)
        EXPECT_NEAR(distance(stage.q1, pair.first, pair.second), distance(stage.q2, pair.first, pair.second),
                    isGpu() ? 1e-8 : 1e-9);
    EXPECT_NEAR(0.0, rate(stage.q2, stage.v2, 1, 2), 1e-9);
    const Eigen::VectorXd before = normalMomenta(pairs, *system, stage.q1, stage.v1);
    const Eigen::VectorXd after = normalMomenta(pairs, *system, stage.q2, stage.v2);
    for (int c = 1; c < 5; ++c)
        EXPECT_NEAR(before[c], after[c], 1e-8 * before.norm()) << c;
    double largestRateChange = 0.0;
    for (int c = 1; c < 5; ++c) {
        const double r1 = rate(stage.q1, stage.v1, pairs[c].first, pairs[c].second);
        const double r2 = rate(stage.q2, stage.v2, pairs[c].first, pairs[c].second);
        largestRateChange = std::max(largestRateChange, std::abs(r2 - r1) / std::abs(r1));
    }
    EXPECT_GT(largestRateChange, 1e-4) << "B did not change: the test would not test the momenta";
    EXPECT_GT(std::abs(dihedral(stage.q2) - dihedral(stage.q1)), 1e-3);
}

TEST_P(FlavorFrozenMomenta, FrozenStageHoldsARedundantFrozenSetAndConservesTheKineticEnergyToThirdOrder) {
    // Neopentane: after the microstep (computed here) the frozen drift must keep all 46 frozen distances, the
    // redundant ones the library leaves out included, while the methyl groups turn.  Without forces the drift is
    // one RATTLE step of the Hamiltonian |p_T|^2 / 2 + mu^T B(q) mu / 2, so the kinetic energy changes by O(h^3):
    // halving the drift divides the change by about 8.  Giving back the normal momenta without the force of
    // mu^T B(q) mu / 2 changes it by O(h) (a factor 2).
    const double tau = 1e-4, drift = 0.004, tolerance = 1e-12;
    double energyChange[2];
    for (int run = 0; run < 2; ++run) {
        const double delta = tau + (run == 0 ? drift : drift / 2);
        vector<Vec3> q0;
        vector<std::array<int, 3>> angles;
        std::unique_ptr<System> system(neopentane(q0, angles));
        const int n = system->getNumParticles();
        vector<Vec3> v0(n);
        std::mt19937 random(8);
        std::normal_distribution<double> gauss;
        for (int i = 0; i < n; ++i)
            v0[i] = Vec3(gauss(random), gauss(random), gauss(random)) * std::sqrt(2.5 / system->getParticleMass(i));
        const FrozenStage stage = runFrozenStage(*system, q0, v0, delta, tau, tolerance, platform(), properties());
        const vector<Vec3>&q1 = stage.q1, &v1 = stage.v1, &q2 = stage.q2;
        vector<std::pair<int, int>> frozen;
        HarmonicBondForce& bonds = dynamic_cast<HarmonicBondForce&>(system->getForce(0));
        for (int b = 0; b < bonds.getNumBonds(); ++b) {
            int i, j;
            double length, k;
            bonds.getBondParameters(b, i, j, length, k);
            frozen.emplace_back(i, j);
        }
        for (const std::array<int, 3>& angle : angles)
            frozen.emplace_back(angle[0], angle[2]);
        ASSERT_EQ(46u, frozen.size());
        for (const std::pair<int, int>& pair : frozen)
            EXPECT_NEAR(distance(q1, pair.first, pair.second), distance(q2, pair.first, pair.second), 1e-9)
                << pair.first << "-" << pair.second;
        energyChange[run] = kineticEnergy(*system, stage.v2) - kineticEnergy(*system, v1);
        // Not a no-op: a hydrogen moved by more than a tenth of its drift, and a methyl group turned about its bond
        // (the distance between hydrogens of two methyls changed).
        EXPECT_GT((q2[2] - q1[2]).dot(q2[2] - q1[2]), 1e-2 * (delta - tau) * (delta - tau) * v1[2].dot(v1[2]));
        EXPECT_GT(std::abs(distance(q2, 2, 6) - distance(q1, 2, 6)), 4e-6);
    }
    std::cout << "kinetic energy change over the frozen drift h, h/2: " << energyChange[0] << ", " << energyChange[1]
              << std::endl;
    EXPECT_GT(std::abs(energyChange[0]), 1e-9) << "too small to measure its order";
    EXPECT_GT(std::abs(energyChange[0]), 6 * std::abs(energyChange[1]));
}

TEST_P(FlavorFrozenMomenta, ATorsionBetweenFrozenAnglesIsSampledWithItsExactDistribution) {
    // With the bonds and angles stiff, the torsion of the chain has the marginal density exp(-k (1 + cos phi) / kT)
    // exactly (the Jacobian of the internal coordinates does not depend on phi, and the System constraint's B is
    // constant), so <cos phi> = -I1(k/kT) / I0(k/kT) and <cos 2 phi> = I2(k/kT) / I0(k/kT).  A Langevin artificial
    // FLAVOR must reproduce both within 4 standard errors of 20 block means.  Restoring the frozen rates instead of
    // the normal momenta, or the momenta without their force, biases <cos 2 phi> by -0.05 to -0.06 (8-15 standard
    // errors).  64 independent chains in one System.
    const double temperature = 300.0, torsionK = 2.0;
    const double kT = BOLTZ * temperature, ratio = torsionK / kT;
    const double exactCos = -std::cyl_bessel_i(1.0, ratio) / std::cyl_bessel_i(0.0, ratio);
    const double exactCos2 = std::cyl_bessel_i(2.0, ratio) / std::cyl_bessel_i(0.0, ratio);
    const int chains = 64;
    std::unique_ptr<System> system(butane(torsionK, chains));
    FlavorIntegrator integrator(0.004, 0.0005, StiffMask);
    integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
    integrator.setTemperature(temperature);
    integrator.setFriction(5.0);
    integrator.setRandomNumberSeed(11);
    Context context(*system, integrator, platform(), properties());
    context.setPositions(butanePositions(chains));
    context.applyConstraints(1e-10);
    context.setVelocitiesToTemperature(temperature, 5);
    integrator.step(500);
    const int blocks = 20, samplesPerBlock = 30, stepsPerSample = 25;
    vector<double> cosBlocks, cos2Blocks;
    for (int block = 0; block < blocks; ++block) {
        double sumCos = 0.0, sumCos2 = 0.0;
        for (int sample = 0; sample < samplesPerBlock; ++sample) {
            integrator.step(stepsPerSample);
            const vector<Vec3> q = positionsOf(context);
            for (int chain = 0; chain < chains; ++chain) {
                const double phi = dihedral(q, 4 * chain);
                sumCos += std::cos(phi);
                sumCos2 += std::cos(2 * phi);
            }
        }
        cosBlocks.push_back(sumCos / (samplesPerBlock * chains));
        cos2Blocks.push_back(sumCos2 / (samplesPerBlock * chains));
    }
    const BlockMean cosPhi = blockMean(cosBlocks), cos2Phi = blockMean(cos2Blocks);
    std::cout << "<cos phi> " << cosPhi.mean << " +- " << cosPhi.standardError << " (exact " << exactCos
              << "), <cos 2 phi> " << cos2Phi.mean << " +- " << cos2Phi.standardError << " (exact " << exactCos2 << ")"
              << std::endl;
    EXPECT_NEAR(exactCos, cosPhi.mean, 4 * cosPhi.standardError);
    EXPECT_NEAR(exactCos2, cos2Phi.mean, 4 * cos2Phi.standardError);
}

TEST_P(FlavorFrozenMomenta, ANearlyDependentFrozenSetGivesBackItsRatesScaledByOneFactor) {
    // A nearly dependent frozen set (B's smallest pivot below 2 % of its diagonal) has normal momenta B^-1 rdot too
    // large to hold; its drift gives back the stored rates along the new directions, all scaled by the one factor
    // that keeps (1/2) rdot^T B^-1 rdot.  The end of the chain turns about the middle bond during the drift, so the
    // factor is not 1, and every frozen distance's rate comes back times that one factor (held momenta would not).
    const double delta = 0.004, tau = 1e-4, tolerance = 1e-12;
    vector<Vec3> q0;
    std::unique_ptr<System> system(nearlyLinearChain(q0));
    const vector<Vec3> v0 = {Vec3(0.2, 0.9, -0.4), Vec3(-0.1, 0.3, 0.5), Vec3(0.4, -0.6, 0.2), Vec3(-0.5, 1.4, -1.1)};
    const FrozenStage stage = runFrozenStage(*system, q0, v0, delta, tau, tolerance, platform(), properties());
    const vector<std::pair<int, int>> pairs = {{0, 1}, {1, 2}, {2, 3}, {0, 2}, {1, 3}};
    for (const std::pair<int, int>& pair : pairs)
        EXPECT_NEAR(distance(stage.q1, pair.first, pair.second), distance(stage.q2, pair.first, pair.second), 1e-9);
    const double scale = rate(stage.q2, stage.v2, 2, 3) / rate(stage.q1, stage.v1, 2, 3);
    EXPECT_GT(std::abs(scale - 1), 1e-6) << "B did not change: the test would not test the scaling";
    for (const std::pair<int, int>& pair : pairs) {
        const double before = rate(stage.q1, stage.v1, pair.first, pair.second);
        EXPECT_NEAR(scale * before, rate(stage.q2, stage.v2, pair.first, pair.second), 1e-8 * (1 + std::abs(before)))
            << pair.first << "-" << pair.second;
    }
}

TEST_P(FlavorFrozenMomenta, AMoleculeAtRestPushedAlongItsFrozenBondsKeepsZeroAngularMomentum) {
    // A bent molecule at rest, its bonds and angle frozen, on an isotropic tether centred on its oxygen: every force
    // is central or along a frozen distance, so the velocities stay along the frozen distances (the velocity solve
    // must converge where the relative velocity left after it is rounding) and the angular momentum about the centre
    // stays 0.
    System system;
    for (double mass : {15.999, 1.008, 1.008})
        system.addParticle(mass);
    addStiffBentMolecules(system, 0);
    CustomExternalForce* tether = new CustomExternalForce("200*(x^2+y^2+z^2)");
    for (int i = 0; i < 3; ++i)
        tether->addParticle(i);
    tether->setForceGroup(SoftGroup);
    system.addForce(tether);
    for (double tolerance : {1e-5, 1e-10}) {
        FlavorIntegrator integrator(0.004, 0.001, StiffMask);
        integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
        integrator.setConstraintTolerance(tolerance);
        Context context(system, integrator, platform(), properties());
        context.setPositions(bentMoleculePositions());
        ASSERT_NO_THROW(integrator.step(20)) << "tolerance " << tolerance;
        const State state = context.getState(State::Positions | State::Velocities);
        Vec3 angularMomentum;
        double speed = 0.0;
        for (int i = 0; i < 3; ++i) {
            angularMomentum += state.getPositions()[i].cross(state.getVelocities()[i]) * system.getParticleMass(i);
            speed = std::max(speed, std::sqrt(state.getVelocities()[i].dot(state.getVelocities()[i])));
        }
        EXPECT_GT(speed, 1e-3) << "the molecule moved";
        // OpenCL's fixed-point forces leave a little more (measured 1.4e-12).
        EXPECT_LT(std::sqrt(angularMomentum.dot(angularMomentum)), isGpu() ? 1e-11 : 1e-12)
            << "tolerance " << tolerance;
    }
}

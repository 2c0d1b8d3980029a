// The exact stiff flow: against matrix exponentials (deterministic and stochastic) and equipartition.

#include "LinearSdeReference.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <utility>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseExact : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseExact);

namespace {

/** Adds a HarmonicBondForce-like isotropic spring of constant k between particles i and j to K. */
void addSpring(MatrixL& K, int i, int j, double k) {
    for (int d = 0; d < 3; ++d) {
        K(3 * i + d, 3 * i + d) += k;
        K(3 * j + d, 3 * j + d) += k;
        K(3 * i + d, 3 * j + d) -= k;
        K(3 * j + d, 3 * i + d) -= k;
    }
}

VectorL stateOf(const vector<Vec3>& q, const vector<Vec3>& v) {
    const int n = 3 * (int)q.size();
    VectorL s(2 * n);
    for (size_t i = 0; i < q.size(); ++i)
        for (int d = 0; d < 3; ++d) {
            s[3 * i + d] = q[i][d];
            s[n + 3 * i + d] = v[i][d];
        }
    return s;
}

constexpr int RingSize = 8;

/**
 * Components of every kind, each with its exact linear SDE: a 2-particle spring with omega = 1e4, a 3-particle
 * chain, a tethered particle (b != 0), a particle pushed by a constant force (a free component), an anisotropic
 * triple (a tether with different x, y, z stiffness and x-y coupling, and two springs) and a ring of 8 springs (the
 * last two are components larger than the compiled sizes).
 */
struct MixedComponents {
    System system;
    LinearSde sde;
    vector<Vec3> q0, v0;
    int numParticles;

    MixedComponents() {
        vector<double> masses = {1.0, 3.0, 2.0, 1.5, 0.7, 4.0, 1.0, 2.5, 1.2};
        for (int i = 0; i < RingSize; ++i)
            masses.push_back(1.0 + 0.25 * i);
        masses.push_back(0.9);
        numParticles = (int)masses.size();
        const int n = 3 * numParticles, lastParticle = numParticles - 1;
        for (double m : masses)
            system.addParticle(m);
        HarmonicBondForce* bonds = new HarmonicBondForce();
        const double k01 = 1e8 * (1.0 * 3.0 / 4.0); // omega = 1e4 for the reduced mass 3/4
        bonds->addBond(0, 1, 0.0, k01);
        bonds->addBond(2, 3, 0.0, 2e4);
        bonds->addBond(3, 4, 0.0, 5e2);
        CustomExternalForce* tether = new CustomExternalForce("0.5*kt*((x-0.3)^2+(y+0.1)^2+z^2)");
        tether->addGlobalParameter("kt", 1e3);
        tether->addParticle(5);
        CustomExternalForce* push = new CustomExternalForce("2.5*x - 1.5*z");
        push->addParticle(6);
        CustomExternalForce* anisotropic = new CustomExternalForce("0.5*(400*x^2+900*y^2+100*z^2)+30*x*y");
        anisotropic->addParticle(7);
        bonds->addBond(7, 8, 0.0, 3e3);
        bonds->addBond(8, lastParticle, 0.0, 2e3);
        for (int i = 0; i < RingSize; ++i)
            bonds->addBond(9 + i, 9 + (i + 1) % RingSize, 0.0, 1e3 * (1 + i));
        for (Force* f : vector<Force*>{bonds, tether, push, anisotropic}) {
            f->setForceGroup(StiffGroup);
            system.addForce(f);
        }
        sde.K = MatrixL::Zero(n, n);
        sde.b = VectorL::Zero(n);
        addSpring(sde.K, 0, 1, k01);
        addSpring(sde.K, 2, 3, 2e4);
        addSpring(sde.K, 3, 4, 5e2);
        addSpring(sde.K, 7, 8, 3e3);
        addSpring(sde.K, 8, lastParticle, 2e3);
        for (int i = 0; i < RingSize; ++i)
            addSpring(sde.K, 9 + i, 9 + (i + 1) % RingSize, 1e3 * (1 + i));
        sde.K(21, 21) += 400;
        sde.K(22, 22) += 900;
        sde.K(23, 23) += 100;
        sde.K(21, 22) += 30;
        sde.K(22, 21) += 30;
        for (int d = 0; d < 3; ++d)
            sde.K(15 + d, 15 + d) = 1e3;
        sde.b[15] = 0.3e3;
        sde.b[16] = -0.1e3;
        sde.b[18] = -2.5;
        sde.b[20] = 1.5;
        for (double m : masses)
            for (int d = 0; d < 3; ++d)
                sde.mass.push_back(m);
        for (int i = 0; i < numParticles; ++i) {
            q0.push_back(Vec3(0.1 * i, 0.05 * (i % 3), -0.02 * i));
            v0.push_back(Vec3(0.3 - 0.1 * i, 0.2, 0.05 * i));
        }
    }

    /**
     * Takes three steps of the splitting from (q0, v0) without friction and returns the relative errors of positions
     * and velocities against the state expected.
     */
    std::pair<double, double> errorsOfThreeSteps(StochasticImpulseIntegrator::Splitting splitting, double H,
                                                 Platform& platform,
                                                 const std::map<std::string, std::string>& properties,
                                                 const VectorL& expected) {
        StochasticImpulseIntegrator integrator(0.0, 0.0, H, StiffMask);
        integrator.setSplitting(splitting);
        Context context(system, integrator, platform, properties);
        context.setPositions(q0);
        context.setVelocities(v0);
        integrator.step(3);
        const int n = 3 * numParticles;
        VectorL actual = stateOf(positionsOf(context), velocitiesOf(context));
        return {(double)((actual.head(n) - expected.head(n)).norm() / expected.head(n).norm()),
                (double)((actual.tail(n) - expected.tail(n)).norm() / expected.tail(n).norm())};
    }
};

} // namespace

TEST_P(ImpulseExact, StiffFlowIsTheMatrixExponential) {
    // Without soft forces and friction a step is the exact flow of the stiff potential, for any H and stiffness.
    MixedComponents test;
    const double H = 0.37;
    for (auto splitting : {StochasticImpulseIntegrator::LieTrotter, StochasticImpulseIntegrator::Strang,
                           StochasticImpulseIntegrator::Yoshida4}) {
        const auto errors = test.errorsOfThreeSteps(splitting, H, platform(), properties(),
                                                    test.sde.mean(stateOf(test.q0, test.v0), 3 * H));
        EXPECT_LE(errors.first, 1e-10) << "splitting " << splitting;
        EXPECT_LE(errors.second, 1e-10) << "splitting " << splitting;
    }
}

TEST_P(ImpulseExact, SoftKicksComposeWithTheExactFlow) {
    // A constant soft force on every particle makes each kick exact, so a step must be the composition of kicks
    // and exact stiff flows its splitting prescribes (Integrator 1, Integrator 3, Remark 2.4), on every kind of
    // component, however the implementation merges them.
    MixedComponents test;
    CustomExternalForce* soft = new CustomExternalForce("-(fx*x + fy*y + fz*z)");
    soft->addPerParticleParameter("fx");
    soft->addPerParticleParameter("fy");
    soft->addPerParticleParameter("fz");
    const int n = 3 * test.numParticles;
    VectorL acceleration(n);
    for (int i = 0; i < test.numParticles; ++i) {
        const vector<double> force = {3.0 - 0.5 * i, 1.0 + 0.25 * (i % 4), -2.0 + 0.1 * i};
        soft->addParticle(i, force);
        for (int d = 0; d < 3; ++d)
            acceleration[3 * i + d] = force[d] / test.sde.mass[3 * i + d];
    }
    soft->setForceGroup(StiffGroup + 1);
    test.system.addForce(soft);

    auto kick = [&](VectorL& state, long double h) { state.tail(n) += h * acceleration; };
    auto flow = [&](VectorL& state, double h) { state = test.sde.mean(state, h); };
    auto strang = [&](VectorL& state, double h) {
        kick(state, h / 2);
        flow(state, h);
        kick(state, h / 2);
    };
    const double H = 0.37, c = 1.0 / (2.0 - std::cbrt(2.0));
    for (auto splitting : {StochasticImpulseIntegrator::LieTrotter, StochasticImpulseIntegrator::Strang,
                           StochasticImpulseIntegrator::Yoshida4}) {
        VectorL expected = stateOf(test.q0, test.v0);
        for (int step = 0; step < 3; ++step) {
            if (splitting == StochasticImpulseIntegrator::LieTrotter) {
                flow(expected, H);
                kick(expected, H);
            } else if (splitting == StochasticImpulseIntegrator::Strang) {
                strang(expected, H);
            } else {
                strang(expected, c * H);
                strang(expected, (1 - 2 * c) * H);
                strang(expected, c * H);
            }
        }
        const auto errors = test.errorsOfThreeSteps(splitting, H, platform(), properties(), expected);
        EXPECT_LE(errors.first, 1e-10) << "splitting " << splitting;
        EXPECT_LE(errors.second, 1e-10) << "splitting " << splitting;
    }
}

namespace {

/** A small molecule of isotropic springs and at most one anisotropic tether, with its linear SDE. */
struct Molecule {
    vector<double> masses;
    struct Spring {
        int i, j;
        double k;
    };
    vector<Spring> springs;
    int tethered = -1; // the particle held by AnisotropicTether, if any
    static constexpr const char* AnisotropicTether = "0.5*(400*x^2+900*y^2+100*z^2)+30*x*y";

    int size() const { return (int)masses.size(); }
    LinearSde sde(double gamma, double kT) const {
        const int n = 3 * size();
        LinearSde result;
        result.K = MatrixL::Zero(n, n);
        result.b = VectorL::Zero(n);
        for (const Spring& s : springs)
            addSpring(result.K, s.i, s.j, s.k);
        if (tethered >= 0) {
            const int r = 3 * tethered;
            result.K(r, r) += 400;
            result.K(r + 1, r + 1) += 900;
            result.K(r + 2, r + 2) += 100;
            result.K(r, r + 1) += 30;
            result.K(r + 1, r) += 30;
        }
        for (double m : masses)
            for (int d = 0; d < 3; ++d)
                result.mass.push_back(m);
        result.gamma = gamma;
        result.kT = kT;
        return result;
    }
};

/**
 * Many independent copies of the molecule take one step of H = 0.1 with friction 5/ps at 300 K from the same state.
 * The sample mean and covariance of a copy's coordinates must match the linear SDE's exact mean and covariance within
 * 5 standard errors (mean: sqrt(S_ii/N); covariance entry: sqrt((S_ii S_jj + S_ij^2)/N)).
 */
void checkOneNoisyStep(const Molecule& molecule, int copies, Platform& platform,
                       const std::map<std::string, std::string>& properties) {
    const double gamma = 5, temperature = 300, H = 0.1;
    const int n = molecule.size(), dims = 6 * n;
    System system;
    HarmonicBondForce* bonds = new HarmonicBondForce();
    CustomExternalForce* tether = new CustomExternalForce(Molecule::AnisotropicTether);
    for (Force* f : vector<Force*>{bonds, tether}) {
        f->setForceGroup(StiffGroup);
        system.addForce(f);
    }
    vector<Vec3> q0, v0, q, v;
    for (int i = 0; i < n; ++i) {
        q0.push_back(Vec3(0.1 + 0.02 * i, 0.01 * (i % 3), -0.05 + 0.01 * i));
        v0.push_back(Vec3(1.0 - 0.3 * i, -0.5 + 0.2 * (i % 4), 0.2));
    }
    for (int c = 0; c < copies; ++c) {
        for (double m : molecule.masses)
            system.addParticle(m);
        for (const Molecule::Spring& s : molecule.springs)
            bonds->addBond(n * c + s.i, n * c + s.j, 0.0, s.k);
        if (molecule.tethered >= 0)
            tether->addParticle(n * c + molecule.tethered);
        q.insert(q.end(), q0.begin(), q0.end());
        v.insert(v.end(), v0.begin(), v0.end());
    }
    StochasticImpulseIntegrator integrator(temperature, gamma, H, StiffMask);
    integrator.setRandomNumberSeed(7);
    Context context(system, integrator, platform, properties);
    context.setPositions(q);
    context.setVelocities(v);
    integrator.step(1);
    const vector<Vec3> q1 = positionsOf(context), v1 = velocitiesOf(context);

    const LinearSde sde = molecule.sde(gamma, BOLTZ * temperature);
    const VectorL mean = sde.mean(stateOf(q0, v0), H);
    const MatrixL covariance = sde.covariance(H);
    vector<VectorL> samples;
    for (int c = 0; c < copies; ++c)
        samples.push_back(stateOf(vector<Vec3>(q1.begin() + n * c, q1.begin() + n * (c + 1)),
                                  vector<Vec3>(v1.begin() + n * c, v1.begin() + n * (c + 1))));
    VectorL sampleMean = VectorL::Zero(dims);
    for (const VectorL& s : samples)
        sampleMean += s / copies;
    MatrixL sampleCovariance = MatrixL::Zero(dims, dims);
    for (const VectorL& s : samples)
        sampleCovariance += (s - sampleMean) * (s - sampleMean).transpose() / (copies - 1);
    for (int i = 0; i < dims; ++i) {
        EXPECT_NEAR((double)mean[i], (double)sampleMean[i], 5 * std::sqrt((double)covariance(i, i) / copies))
            << "mean of coordinate " << i;
        for (int j = 0; j <= i; ++j) {
            double se =
                std::sqrt((double)(covariance(i, i) * covariance(j, j) + covariance(i, j) * covariance(i, j)) / copies);
            EXPECT_NEAR((double)covariance(i, j), (double)sampleCovariance(i, j), 5 * se)
                << "covariance " << i << "," << j;
        }
    }
}

} // namespace

TEST_P(ImpulseExact, OneNoisyStepHasTheExactMeanAndCovariance) {
    // A spring between masses 1 and 2 with omega = 50 (a compiled flow), 4000 copies.
    const double mu = 2.0 / 3.0, omega = 50;
    checkOneNoisyStep(Molecule{{1.0, 2.0}, {{0, 1, omega * omega * mu}}}, 4000, platform(), properties());
}

TEST_P(ImpulseExact, OneNoisyStepOfLargeComponentsHasTheExactMeanAndCovariance) {
    // A ring of 8 springs (isotropic, 8 rows) and an anisotropic triple (9 rows): both take the general path through
    // mode space.  2000 copies.
    Molecule molecule;
    for (int i = 0; i < RingSize; ++i) {
        molecule.masses.push_back(1.0 + 0.25 * i);
        molecule.springs.push_back({i, (i + 1) % RingSize, 1e3 * (1 + i)});
    }
    molecule.masses.insert(molecule.masses.end(), {2.5, 1.2, 0.9});
    molecule.springs.push_back({RingSize, RingSize + 1, 3e3});
    molecule.springs.push_back({RingSize + 1, RingSize + 2, 2e3});
    molecule.tethered = RingSize;
    checkOneNoisyStep(molecule, 2000, platform(), properties());
}

TEST_P(ImpulseExact, EquipartitionWithSoftForces) {
    // 400 copies of a pair with a stiff spring k (omega = 100 for unit masses... relative frequency sqrt(2k)) and a
    // soft harmonic tether a r^2/2 on each particle: the Boltzmann averages are <K> = (3/2) kT per particle and, per
    // copy, <V_stiff> = (3/2) kT * 2k/(a + 2k).  Strang SIM with H = 0.02 (sqrt(a) H = 0.02: splitting bias
    // ~(sqrt(a) H)^2 = 4e-4), friction 2/ps; 5 standard errors from 20 block means, plus 0.002 for the bias.
    const int copies = 400;
    const double a = 1.0, k = 5e3, temperature = 300, kT = BOLTZ * temperature;
    System system;
    HarmonicBondForce* stiff = new HarmonicBondForce();
    stiff->setForceGroup(StiffGroup);
    CustomExternalForce* soft = new CustomExternalForce("0.5*a*(x^2+y^2+z^2)");
    soft->addGlobalParameter("a", a);
    for (int c = 0; c < copies; ++c) {
        system.addParticle(1.0);
        system.addParticle(1.0);
        stiff->addBond(2 * c, 2 * c + 1, 0.0, k);
        soft->addParticle(2 * c);
        soft->addParticle(2 * c + 1);
    }
    system.addForce(stiff);
    system.addForce(soft);
    StochasticImpulseIntegrator integrator(temperature, 2.0, 0.02, StiffMask);
    integrator.setRandomNumberSeed(99);
    Context context(system, integrator, platform(), properties());
    context.setPositions(vector<Vec3>(2 * copies));
    integrator.step(500);
    const int blocks = 20, samples = 10;
    vector<double> kinetic, stiffEnergy;
    for (int b = 0; b < blocks; ++b) {
        double kin = 0, pot = 0;
        for (int s = 0; s < samples; ++s) {
            integrator.step(50);
            kin += context.getState(State::Energy).getKineticEnergy() / (2 * copies * 1.5 * kT);
            pot += context.getState(State::Energy, false, StiffMask).getPotentialEnergy() /
                   (copies * 1.5 * kT * 2 * k / (a + 2 * k));
        }
        kinetic.push_back(kin / samples);
        stiffEnergy.push_back(pot / samples);
    }
    for (auto* series : {&kinetic, &stiffEnergy}) {
        const BlockMean m = blockMean(*series);
        EXPECT_NEAR(1.0, m.mean, 5 * m.standardError + 0.002)
            << (series == &kinetic ? "kinetic" : "stiff potential") << " energy ratio";
    }
}

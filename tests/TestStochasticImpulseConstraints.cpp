// Constraints beside stiff components: rigid water whose oxygen is the core of a Drude pair.  The constraint force
// acts on the core alone, as impulses at the ends of the stiff flow (RATTLE), and the pair's exact flow carries them
// to the Drude particle; constraints are held to tolerance, and the constrained flow is the exact one to second
// order.

#include "DrudeWater.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/VerletIntegrator.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <cmath>
#include <map>
#include <string>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseConstraints : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseConstraints);

namespace {

/**
 * A core A with its Drude particle D, constrained to an atom B that a constant soft force F pulls along the bond (x):
 * the three accelerate as one body, a = F / (m_A + m_D + m_B), and the spring alone accelerates D, so in the steady
 * state r = q_D - q_A = -m_D a / k and D moves with A.  The constraint acts on A only, and the pair's flow carries the
 * impulse to D; in the Drude mode it is scaled as the splitting's kicks are, so that, damped (20/ps at 0 K) to its
 * steady state, r is exact to rounding at omega H = 1.04 and 2.07 under Filtered and Warped, whose kicks have the exact
 * mean under a constant force (Strang's plain kicks would leave r at (xi/2) cot(xi/2) of it: 0.91 and 0.62).  With
 * the Middle placement the step's end velocities are processed for the closing half of the constraint impulse.
 */
void expectExactLag(Platform& platform, const std::map<std::string, std::string>& properties,
                    StochasticImpulseIntegrator::Splitting splitting,
                    StochasticImpulseIntegrator::ThermostatPlacement placement) {
    const double coreMass = OxygenMass - DrudeMass, atomMass = 2.0, force = 500.0, length = 0.1;
    const double acceleration = force / (coreMass + DrudeMass + atomMass), lag = -DrudeMass * acceleration / DrudeK;
    System system;
    const int core = system.addParticle(coreMass), drude = system.addParticle(DrudeMass),
              atom = system.addParticle(atomMass);
    system.addConstraint(core, atom, length);
    HarmonicBondForce* spring = new HarmonicBondForce();
    spring->addBond(core, drude, 0.0, DrudeK);
    spring->setForceGroup(StiffGroup);
    system.addForce(spring);
    CustomExternalForce* pull = new CustomExternalForce("-f*x");
    pull->addGlobalParameter("f", force);
    pull->addParticle(atom);
    system.addForce(pull);
    for (double stepSize : {0.001, 0.002}) {
        SCOPED_TRACE(stepSize);
        StochasticImpulseIntegrator integrator(0.0, 0.0, stepSize, StiffMask);
        integrator.setSplitting(splitting);
        integrator.setThermostatPlacement(placement);
        integrator.setStiffModeTemperature(0.0);
        integrator.setStiffModeFriction(20.0);
        integrator.setConstraintTolerance(1e-12);
        Context context(system, integrator, platform, properties);
        context.setPositions({Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(length, 0, 0)});
        const int steps = (int)std::lround(3.0 / stepSize);
        integrator.step(steps);
        const vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
        // The body has travelled about 100 nm: r is a difference of coordinates rounded to about 1e-14 nm.
        const Vec3 r = q[drude] - q[core];
        EXPECT_NEAR(lag, r[0], 1e-12);
        EXPECT_EQ(0.0, r[1]);
        EXPECT_EQ(0.0, r[2]);
        // The constraint holds, in positions and velocities, the Drude particle moves with its core, and the momentum
        // is the impulse of F.
        EXPECT_NEAR(length, q[atom][0] - q[core][0], 1e-10);
        EXPECT_NEAR(v[atom][0], v[core][0], 1e-12 * std::abs(v[atom][0]));
        EXPECT_NEAR(v[drude][0], v[core][0], 1e-9 * std::abs(v[atom][0]));
        const double momentum = coreMass * v[core][0] + DrudeMass * v[drude][0] + atomMass * v[atom][0];
        EXPECT_NEAR(force * stepSize * steps, momentum, 1e-9 * momentum);
        EXPECT_GT(std::abs(lag), 1e-5);
    }
}

} // namespace

TEST_P(ImpulseConstraints, AnAcceleratedConstrainedCoreHoldsItsDrudeAtTheExactLagUnderFiltered) {
    expectExactLag(platform(), properties(), StochasticImpulseIntegrator::Filtered,
                   StochasticImpulseIntegrator::Throughout);
}

TEST_P(ImpulseConstraints, AnAcceleratedConstrainedCoreHoldsItsDrudeAtTheExactLagUnderWarpedMiddle) {
    expectExactLag(platform(), properties(), StochasticImpulseIntegrator::Warped, StochasticImpulseIntegrator::Middle);
}

TEST_P(ImpulseConstraints, RigidDrudeWaterConvergesAtSecondOrderToTheExactConstrainedFlow) {
    // Four rigid Drude waters, tethered, their Drudes in a field, at 300 K without friction: Strang's positions after
    // 20 fs at H = 0.5, 0.25 and 0.125 fs against VerletIntegrator at 0.0025 fs (omega h = 0.0026 for the Drude
    // spring: the exact constrained flow to about 1e-11 nm).  A second-order method quarters its error with each
    // halving of H; an error of the constraint force's effect on the Drude that is first order (one applied a step
    // late) would halve it.
    DrudeWater water(4, false);
    // Every run starts from OpenMM's own draw at 300 K: the SIMs below have a stiff-mode temperature, with which their
    // draw would give the Drudes that temperature, so they take the draw of a SIM without one (openmmDraw).
    vector<Vec3> openmmDraw;
    auto run = [&](Integrator& integrator, int steps, bool ownDraw) {
        Context context(water.system, integrator, platform(), properties());
        context.setPositions(water.positions);
        if (ownDraw)
            context.setVelocitiesToTemperature(300.0, 3);
        else
            context.setVelocities(openmmDraw);
        context.applyConstraints(1e-12);
        context.applyVelocityConstraints(1e-12);
        integrator.step(steps);
        return positionsOf(context);
    };
    {
        StochasticImpulseIntegrator plain(0.0, 0.0, 1e-4, StiffMask);
        Context context(water.system, plain, platform(), properties());
        context.setPositions(water.positions);
        context.setVelocitiesToTemperature(300.0, 3);
        openmmDraw = context.getState(State::Velocities).getVelocities();
    }
    VerletIntegrator verlet(2.5e-6);
    verlet.setConstraintTolerance(1e-12);
    const double time = 0.02;
    const vector<Vec3> exact = run(verlet, (int)std::lround(time / 2.5e-6), true);
    vector<double> errors;
    for (double stepSize : {5e-4, 2.5e-4, 1.25e-4}) {
        StochasticImpulseIntegrator integrator(0.0, 0.0, stepSize, StiffMask);
        integrator.setSplitting(StochasticImpulseIntegrator::Strang);
        integrator.setStiffModeTemperature(0.0);
        integrator.setStiffModeFriction(0.0);
        integrator.setConstraintTolerance(1e-12);
        const vector<Vec3> q = run(integrator, (int)std::lround(time / stepSize), false);
        double sum = 0;
        for (size_t i = 0; i < q.size(); ++i)
            sum += (q[i] - exact[i]).dot(q[i] - exact[i]);
        errors.push_back(std::sqrt(sum / q.size()));
    }
    // Measured: 1.2e-5, 2.9e-6, 7.3e-7 nm (ratios 0.249, 0.249).
    EXPECT_LT(errors[0], 1e-4);
    for (int k = 1; k < 3; ++k) {
        SCOPED_TRACE(k);
        EXPECT_NEAR(0.25, errors[k] / errors[k - 1], 0.03);
    }
}

TEST_P(ImpulseConstraints, RigidDrudeWaterKeepsItsConstraintsWithAColdDrudeBathUnderStrangAndFiltered) {
    // Every particle tethered, the Drudes pulled by a field, 300 K at 5/ps with the Drude modes at 1 K and 20/ps;
    // SETTLE for the water and, with a constrained chain whose middle atom carries a Drude particle, CCMA.  After every
    // step each constraint holds to 1e-7 of its length (tolerance 1e-9) and each constrained pair's relative velocity
    // is perpendicular to its bond to 1e-6 of the speed scale.
    DrudeWater water(16, false);
    System& system = water.system;
    const int a = system.addParticle(12.0), b = system.addParticle(11.6), c = system.addParticle(14.0),
              d = system.addParticle(0.4);
    system.addConstraint(a, b, 0.15);
    system.addConstraint(b, c, 0.14);
    HarmonicAngleForce* angle = new HarmonicAngleForce();
    angle->addAngle(a, b, c, 1.9, 300.0);
    system.addForce(angle);
    HarmonicBondForce* chainDrude = new HarmonicBondForce();
    chainDrude->addBond(b, d, 0.0, DrudeK);
    chainDrude->setForceGroup(StiffGroup);
    system.addForce(chainDrude);
    water.positions.push_back(Vec3(2, 2, 2));
    water.positions.push_back(Vec3(2.15, 2, 2));
    water.positions.push_back(Vec3(2.15 + 0.14 * std::cos(1.2), 2 + 0.14 * std::sin(1.2), 2));
    water.positions.push_back(Vec3(2.151, 2.001, 2));
    for (auto splitting : {StochasticImpulseIntegrator::Strang, StochasticImpulseIntegrator::Filtered}) {
        SCOPED_TRACE(splitting == StochasticImpulseIntegrator::Strang ? "Strang" : "Filtered");
        StochasticImpulseIntegrator integrator(300.0, 5.0, 0.002, StiffMask);
        integrator.setSplitting(splitting);
        integrator.setStiffModeTemperature(1.0);
        integrator.setStiffModeFriction(20.0);
        integrator.setConstraintTolerance(1e-9);
        integrator.setRandomNumberSeed(17);
        Context context(system, integrator, platform(), properties());
        context.setPositions(water.positions);
        context.setVelocitiesToTemperature(300.0, 3);
        context.applyConstraints(1e-9);
        context.applyVelocityConstraints(1e-9);
        double worstLength = 0, worstVelocity = 0;
        for (int step = 0; step < 200; ++step) {
            integrator.step(1);
            const vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
            for (int k = 0; k < system.getNumConstraints(); ++k) {
                int i, j;
                double length;
                system.getConstraintParameters(k, i, j, length);
                const Vec3 r = q[j] - q[i], u = v[j] - v[i];
                const double distance = std::sqrt(r.dot(r));
                worstLength = std::max(worstLength, std::abs(distance - length) / length);
                // Speed scale sqrt(kT/m) of a hydrogen at 300 K: about 1.6 nm/ps.
                worstVelocity = std::max(worstVelocity, std::abs(u.dot(r)) / distance / 1.6);
            }
        }
        EXPECT_LT(worstLength, 1e-7);
        EXPECT_LT(worstVelocity, 1e-6);
        // The Drude particles stay with their cores (a sanity bound, 0.01 nm: the field displaces them by ~1e-3 nm).
        const vector<Vec3> q = positionsOf(context);
        for (int m = 0; m < water.molecules; ++m) {
            const Vec3 r = q[4 * m + 3] - q[4 * m];
            EXPECT_LT(std::sqrt(r.dot(r)), 0.01);
        }
    }
}

TEST_P(ImpulseConstraints, RigidDrudeWaterHasTheBathTemperatureAtLargeSteps) {
    // 100 free rigid Drude waters (no soft force), 300 K at 2/ps, the Drude modes at 1 K and 20/ps, H = 4 fs: the
    // kinetic temperature of the 6 rigid-body degrees of freedom per molecule (pairs counted at their centre of mass)
    // must be 300 K, and that of the Drude motion 1 K, within 5 standard errors of 20 block means plus 1% for the
    // splitting.  A velocity left uncorrected for the constraint correction of the positions loses a fraction
    // (rotation angle per step)^2 of the rotational energy each step: about 4% per 4 fs step at 300 K.
    DrudeWater water(100, true);
    System& system = water.system;
    while (system.getNumForces() > 1)
        system.removeForce(1);
    const double mPair = OxygenMass, mu = (OxygenMass - DrudeMass) * DrudeMass / OxygenMass;
    for (auto splitting : {StochasticImpulseIntegrator::Strang, StochasticImpulseIntegrator::Filtered}) {
        SCOPED_TRACE(splitting == StochasticImpulseIntegrator::Strang ? "Strang" : "Filtered");
        StochasticImpulseIntegrator integrator(300.0, 2.0, 0.004, StiffMask);
        integrator.setSplitting(splitting);
        integrator.setStiffModeTemperature(1.0);
        integrator.setStiffModeFriction(20.0);
        integrator.setConstraintTolerance(1e-8);
        integrator.setRandomNumberSeed(41);
        Context context(system, integrator, platform(), properties());
        context.setPositions(water.positions);
        context.applyConstraints(1e-8);
        integrator.step(1000);
        const int blocks = 20, samples = 10;
        vector<double> rigid, drude;
        for (int b = 0; b < blocks; ++b) {
            double tr = 0, td = 0;
            for (int s = 0; s < samples; ++s) {
                integrator.step(20);
                const vector<Vec3> v = velocitiesOf(context);
                for (int m = 0; m < water.molecules; ++m) {
                    const int o = 4 * m;
                    const Vec3 vc = (v[o] * (OxygenMass - DrudeMass) + v[o + 3] * DrudeMass) / mPair;
                    const Vec3 vr = v[o + 3] - v[o];
                    const double ke =
                        mPair * vc.dot(vc) + HydrogenMass * (v[o + 1].dot(v[o + 1]) + v[o + 2].dot(v[o + 2]));
                    tr += ke / (6 * BOLTZ * 300.0) / (water.molecules * samples);
                    td += mu * vr.dot(vr) / (3 * BOLTZ * 1.0) / (water.molecules * samples);
                }
            }
            rigid.push_back(tr);
            drude.push_back(td);
        }
        for (auto* series : {&rigid, &drude}) {
            const BlockMean m = blockMean(*series);
            EXPECT_NEAR(1.0, m.mean, 5 * m.standardError + 0.01)
                << (series == &rigid ? "rigid-body" : "Drude") << " temperature ratio";
        }
    }
}

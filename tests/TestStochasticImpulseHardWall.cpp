// The hard wall of the stiff pairs (StochasticImpulseIntegrator::setMaxDrudeDistance): off by default and inert while
// no pair reaches it; a pair past it ends inside, moving inward at the stiff modes' thermal speed with its tangential
// and centre-of-mass motion kept (or only the Drude particle moving when its parent is constrained); its positions are
// set before the closing kick, which reads their forces, so a step costs one force evaluation with the wall as without
// it, and its velocities after the kick, so a pair that the field holds out at the wall stays within it; a pair past
// twice the wall stops the step with a clear error; the setting survives serialization and bad values are rejected.

#include "CountingForce.h"
#include "ExpectRejected.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/State.h"
#include "openmm/System.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include "openmm/serialization/XmlSerializer.h"
#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <vector>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseHardWall : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseHardWall);

namespace {

const double CoreMass = 15.6, DrudeMass = 0.4, Spring = 4e5, Step = 0.001, DrudeTemperature = 1.0;

/**
 * A Drude pair (core 0, Drude 1) on a zero-length spring (group 1), a weak soft well of stiffness well on the core
 * (group 0); with constrainedCore, a third particle tied to the core by a constraint.
 */
System drudePair(bool constrainedCore, double well = 1.0) {
    System system;
    system.addParticle(CoreMass);
    system.addParticle(DrudeMass);
    auto* spring = new HarmonicBondForce();
    spring->addBond(0, 1, 0.0, Spring);
    spring->setForceGroup(1);
    system.addForce(spring);
    auto* soft = new CustomExternalForce("0.5*well*(x^2+y^2+z^2)");
    soft->addGlobalParameter("well", well);
    soft->addParticle(0, {});
    system.addForce(soft);
    if (constrainedCore) {
        system.addParticle(1.0);
        system.addConstraint(0, 2, 0.1);
    }
    return system;
}

std::unique_ptr<StochasticImpulseIntegrator> makeIntegrator(double wall) {
    auto integrator = std::make_unique<StochasticImpulseIntegrator>(300.0, 0.0, Step, 1 << 1);
    integrator->setStiffModeTemperature(DrudeTemperature);
    integrator->setMaxDrudeDistance(wall);
    return integrator;
}

/** The Drude 0.005 nm from its core, moving outward at radialSpeed relative to it, plus tangential motion. */
void start(Context& context, bool constrainedCore, double radialSpeed) {
    vector<Vec3> positions = {Vec3(0.1, 0.2, 0.3), Vec3(0.105, 0.2, 0.3)};
    vector<Vec3> velocities = {Vec3(-0.3, 0.2, 0.1), Vec3(-0.3 + radialSpeed, 1.5, -0.7)};
    if (constrainedCore) {
        positions.push_back(Vec3(0.1, 0.3, 0.3));
        velocities.push_back(Vec3(-0.3, 0.2, 0.1));
        velocities[0] = Vec3(-0.3, 0.2, 0.1);
    }
    context.setPositions(positions);
    context.setVelocities(velocities);
}

/** One step from the start, without the wall (0) or with it, the core's well of stiffness well. */
State stepOnce(Platform& platform, const std::map<std::string, std::string>& properties, bool constrainedCore,
               double radialSpeed, double wall, double well = 1.0) {
    System system = drudePair(constrainedCore, well);
    auto integrator = makeIntegrator(wall);
    Context context(system, *integrator, platform, properties);
    start(context, constrainedCore, radialSpeed);
    integrator->step(1);
    return context.getState(State::Positions | State::Velocities);
}

} // namespace

TEST_P(ImpulseHardWall, IsOffByDefaultAndInertWhileNoPairReachesIt) {
    StochasticImpulseIntegrator plain(300.0, 0.0, Step, 1 << 1);
    EXPECT_EQ(0.0, plain.getMaxDrudeDistance());
    // 5 nm/ps outward: the pair stays within 0.02 nm, so a wall there changes nothing, bit for bit.
    const State without = stepOnce(platform(), properties(1), false, 5.0, 0.0);
    const State with = stepOnce(platform(), properties(1), false, 5.0, 0.02);
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(without.getPositions()[i], with.getPositions()[i]);
        EXPECT_EQ(without.getVelocities()[i], with.getVelocities()[i]);
    }
}

// 30 nm/ps outward carries the pair to about 0.028 nm: past a 0.02 nm wall, within twice it.  The well is off, so
// that the closing kick, which reads the forces at the walled positions, adds nothing and the wall's own action shows
// exactly.
TEST_P(ImpulseHardWall, PutsAPairPastItBackInsideMovingInwardAtTheThermalSpeed) {
    const double wall = 0.02, thermalSpeed = std::sqrt(BOLTZ * DrudeTemperature / DrudeMass);
    for (bool constrainedCore : {false, true}) {
        const State free = stepOnce(platform(), properties(1), constrainedCore, 30.0, 0.0, 0.0);
        const State walled = stepOnce(platform(), properties(1), constrainedCore, 30.0, wall, 0.0);
        const vector<Vec3>& q = free.getPositions();
        const vector<Vec3>& v = free.getVelocities();
        const Vec3 delta = q[1] - q[0];
        const double r = std::sqrt(delta.dot(delta));
        ASSERT_GT(r, wall);
        ASSERT_LT(r, 2 * wall);
        const Vec3 direction = delta / r;
        const vector<Vec3>& qw = walled.getPositions();
        const vector<Vec3>& vw = walled.getVelocities();
        const Vec3 deltaWalled = qw[1] - qw[0];
        EXPECT_LT(std::sqrt(deltaWalled.dot(deltaWalled)), wall) << constrainedCore;
        // Along the pair's old axis: inward at the thermal speed; across it, the motion the step gave each particle.
        EXPECT_NEAR(-thermalSpeed, (vw[1] - vw[0]).dot(direction), 1e-10) << constrainedCore;
        for (int i = 0; i < 2; ++i) {
            const Vec3 across = v[i] - direction * v[i].dot(direction);
            const Vec3 acrossWalled = vw[i] - direction * vw[i].dot(direction);
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(across[k], acrossWalled[k], 1e-10) << constrainedCore;
        }
        if (constrainedCore) {
            EXPECT_EQ(q[0], qw[0]);
            EXPECT_EQ(v[0], vw[0]);
            EXPECT_EQ(q[2], qw[2]);
        } else {
            const Vec3 centre = (q[0] * CoreMass + q[1] * DrudeMass) / (CoreMass + DrudeMass);
            const Vec3 centreWalled = (qw[0] * CoreMass + qw[1] * DrudeMass) / (CoreMass + DrudeMass);
            const Vec3 momentum = v[0] * CoreMass + v[1] * DrudeMass;
            const Vec3 momentumWalled = vw[0] * CoreMass + vw[1] * DrudeMass;
            for (int k = 0; k < 3; ++k) {
                EXPECT_NEAR(centre[k], centreWalled[k], 1e-13);
                EXPECT_NEAR(momentum[k], momentumWalled[k], 1e-10);
            }
        }
    }
}

// With the well on, the soft forces are evaluated as often with the wall as without it: the closing kick reads them at
// the walled positions and the next step reuses them.
TEST_P(ImpulseHardWall, CostsNoForceEvaluation) {
    int evaluations[2];
    for (int walled : {0, 1}) {
        System system = drudePair(false);
        auto* counter = new CountingForce();
        system.addForce(counter);
        auto integrator = makeIntegrator(walled ? 0.02 : 0.0);
        Context context(system, *integrator, platform(), properties(1));
        start(context, false, 30.0);
        integrator->step(4);
        evaluations[walled] = counter->getCount();
        if (walled) { // the wall moved the pair in the first step
            const State free = stepOnce(platform(), properties(1), false, 30.0, 0.0);
            const Vec3 delta = free.getPositions()[1] - free.getPositions()[0];
            ASSERT_GT(std::sqrt(delta.dot(delta)), 0.02);
        }
    }
    EXPECT_EQ(evaluations[0], evaluations[1]);
}

// A field that holds the pair 0.021 nm apart, just past a 0.02 nm wall, at 2 fs (Warped, exact static response): in
// a kick-flow-kick step the velocity before the closing kick of a pair at rest in its field is -(H/2) F/mu, inward,
// about 22 nm/ps here, which the kick cancels.  After the kick the wall sets the velocity the pair has, and the pair
// stays within the wall for 200 steps; before it the wall would replace that inward velocity by the thermal one and the
// kicks would send the pair past twice the wall within a step.
TEST_P(ImpulseHardWall, SetsSpeedsAfterTheClosingKickSoThatAPairHeldOutByItsFieldStaysWithinIt) {
    const double wall = 0.02, held = 0.021, stepSize = 0.002;
    // The pair's largest separation at the steps' ends over 200 steps from rest 0.0199 nm apart.
    auto farthest = [&](double maxDistance) {
        System system = drudePair(false);
        auto* field = new CustomExternalForce("-f*x"); // a uniform field on a neutral pair: the core pulled back
        field->addPerParticleParameter("f");
        field->addParticle(1, {Spring * held});
        field->addParticle(0, {-Spring * held});
        system.addForce(field);
        StochasticImpulseIntegrator integrator(300.0, 0.0, stepSize, 1 << 1);
        integrator.setSplitting(StochasticImpulseIntegrator::Warped);
        integrator.setStiffModeTemperature(DrudeTemperature);
        integrator.setMaxDrudeDistance(maxDistance);
        Context context(system, integrator, platform(), properties(1));
        context.setPositions({Vec3(0.1, 0.2, 0.3), Vec3(0.1 + 0.0199, 0.2, 0.3)});
        context.setVelocities({Vec3(), Vec3()});
        double result = 0.0;
        for (int i = 0; i < 200; ++i) {
            integrator.step(1);
            const vector<Vec3> q = context.getState(State::Positions).getPositions();
            const Vec3 delta = q[1] - q[0];
            result = std::max(result, std::sqrt(delta.dot(delta)));
        }
        return result;
    };
    EXPECT_GT(farthest(0.0), wall); // without the wall the pair oscillates about 0.021 nm
    EXPECT_LE(farthest(wall), wall);
}

TEST_P(ImpulseHardWall, APairPastTwiceTheWallStopsTheStepAndTheContextStaysUsable) {
    System system = drudePair(false);
    auto integrator = makeIntegrator(0.01);
    Context context(system, *integrator, platform(), properties(1));
    start(context, false, 30.0);
    // The first step carries the pair past twice the wall; on the GPU platforms the step's kernels leave a flag that is
    // read, without stalling the device, where the next step starts.
    expectRejected([&] { integrator->step(2); }, {"particles 1 and 0", "twice the hard wall", "setMaxDrudeDistance"});
    integrator->setMaxDrudeDistance(0.02);
    start(context, false, 30.0);
    integrator->step(3);
    const vector<Vec3> q = context.getState(State::Positions).getPositions();
    const Vec3 delta = q[1] - q[0];
    EXPECT_LT(std::sqrt(delta.dot(delta)), 0.02);
}

TEST_P(ImpulseHardWall, BadValuesAndTheMetropolisAdjustmentAreRejected) {
    auto integrator = makeIntegrator(0.02);
    expectRejected([&] { integrator->setMaxDrudeDistance(-0.1); }, {"maxDrudeDistance", "-0.1"});
    EXPECT_EQ(0.02, integrator->getMaxDrudeDistance());
    System system = drudePair(false);
    integrator->setMetropolis(true);
    Context context(system, *integrator, platform(), properties(1));
    start(context, false, 1.0);
    expectRejected([&] { integrator->step(1); }, {"Metropolis", "hard wall"});
    integrator->setMetropolis(false);
    integrator->step(1);
}

TEST(ImpulseHardWallApi, SurvivesSerializationAndIsDescribed) {
    StochasticImpulseIntegrator integrator(300.0, 1.0, Step, 1 << 1);
    integrator.setMaxDrudeDistance(0.02);
    std::stringstream buffer;
    XmlSerializer::serialize<Integrator>(&integrator, "Integrator", buffer);
    std::unique_ptr<Integrator> copy(XmlSerializer::deserialize<Integrator>(buffer));
    EXPECT_EQ(0.02, dynamic_cast<StochasticImpulseIntegrator&>(*copy).getMaxDrudeDistance());
    EXPECT_NE(std::string::npos, integrator.describeStep().find("E(H) W K_S(H/2) W_v"));
    EXPECT_NE(std::string::npos, integrator.describeStep().find("hard wall of the stiff pairs at 0.02 nm"));
}

// Both integrators against what a user trips on: foreign or truncated checkpoints, massless particles, stiff groups
// outside the integration force groups, a FLAVOR without soft forces, repeated friction particles, nonlinear stiff
// groups given to SIM.

#include "CheckpointGuards.h"
#include "CountingForce.h"
#include "ExpectRejected.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/OpenMMException.h"
#include "openmm/VerletIntegrator.h"
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <sstream>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::string;
using std::vector;

class IntegratorGuards : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(IntegratorGuards);

namespace {

/** The FPU chain with three stiff springs and a soft force c x^2 on particle 0 whose global parameter c is 0. */
System* fpuWithParameter() {
    System* system = fpuSystem(3, 50.0);
    CustomExternalForce* extra = new CustomExternalForce("c*x^2");
    extra->addGlobalParameter("c", 0.0);
    extra->addParticle(0);
    extra->setForceGroup(SoftGroup);
    system->addForce(extra);
    return system;
}

vector<Vec3> someVelocities(int n, double scale) {
    vector<Vec3> v(n);
    for (int i = 0; i < n; ++i)
        v[i] = Vec3(scale * (0.3 + 0.1 * i), -0.2 * scale, 0.05 * scale * i);
    return v;
}

string checkpointOf(Context& context) {
    std::ostringstream stream;
    context.createCheckpoint(stream);
    return stream.str();
}

/** The checkpoint of a Context of the same System with OpenMM's VerletIntegrator, at other positions. */
string verletCheckpoint(const System& system, Platform& platform, const std::map<string, string>& properties) {
    VerletIntegrator verlet(0.001);
    Context context(system, verlet, platform, properties);
    context.setPositions(fpuPositions({0.7, 0.1, -0.3}, {0.01, 0.02, 0.0}));
    verlet.step(3);
    return checkpointOf(context);
}

/** The integrator's own checkpoints of another run, cut short at three places. */
vector<ForeignCheckpoint> truncated(const string& full, const string& integratorName) {
    return {{"cut by one byte", full.substr(0, full.size() - 1), {integratorName, "loadCheckpoint", "truncated"}},
            {"cut inside the random streams",
             full.substr(0, full.size() - 50),
             {integratorName, "loadCheckpoint", "truncated"}},
            {"cut inside OpenMM's part", full.substr(0, full.size() / 2), {integratorName, "loadCheckpoint"}}};
}

void stepFlavor(Context& context, int steps) {
    context.getIntegrator().step(steps);
}

} // namespace

TEST_P(IntegratorGuards, FlavorRejectsForeignCheckpointsAndKeepsTheContext) {
    std::unique_ptr<System> system(fpuWithParameter());
    auto configure = [](FlavorIntegrator& integrator) {
        integrator.setTemperature(300);
        integrator.setFriction(5);
        integrator.setRandomNumberSeed(17);
    };
    auto setUp = [&](FlavorIntegrator& integrator, Context& context) {
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        context.setVelocities(someVelocities(6, 1.0));
        context.setParameter("c", 0.25);
        integrator.step(4);
    };
    FlavorIntegrator integrator(0.01, 0.001, StiffMask), twinIntegrator(0.01, 0.001, StiffMask);
    configure(integrator);
    configure(twinIntegrator);
    Context context(*system, integrator, platform(), properties()),
        twin(*system, twinIntegrator, platform(), properties());
    setUp(integrator, context);
    setUp(twinIntegrator, twin);

    StochasticImpulseIntegrator sim(300, 5, 0.01, StiffMask);
    Context simContext(*system, sim, platform(), properties());
    simContext.setPositions(fpuPositions({0.5, 0, 0}, {0.01, 0, 0}));
    sim.step(2);
    FlavorIntegrator other(0.01, 0.002, StiffMask);
    other.setFriction(1);
    other.setRandomNumberSeed(99);
    Context otherContext(*system, other, platform(), properties());
    otherContext.setPositions(fpuPositions({0.2, 0.1, 0}, {0.03, 0, 0}));
    other.step(3);

    vector<ForeignCheckpoint> foreign = truncated(checkpointOf(otherContext), "FlavorIntegrator");
    foreign.push_back({"VerletIntegrator's",
                       verletCheckpoint(*system, platform(), properties()),
                       {"FlavorIntegrator", "loadCheckpoint", "no data of this integrator", "VerletIntegrator"}});
    foreign.push_back({"StochasticImpulseIntegrator's",
                       checkpointOf(simContext),
                       {"FlavorIntegrator", "loadCheckpoint", "made with StochasticImpulseIntegrator"}});
    expectForeignCheckpointsRejected(context, stepFlavor, twin, stepFlavor, foreign);

    // The integrator's own checkpoint still loads and continues identically.
    const string own = checkpointOf(context);
    integrator.step(6);
    const ContextSnapshot after(context);
    std::istringstream stream(own);
    context.loadCheckpoint(stream);
    integrator.step(6);
    ContextSnapshot(context).expectEqual(after, "own checkpoint");
}

TEST_P(IntegratorGuards, ImpulseRejectsForeignCheckpointsAndKeepsTheContext) {
    std::unique_ptr<System> system(fpuWithParameter());
    auto setUp = [&](StochasticImpulseIntegrator& integrator, Context& context) {
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        context.setVelocities(someVelocities(6, 1.0));
        context.setParameter("c", 0.25);
        integrator.step(4);
    };
    StochasticImpulseIntegrator integrator(300, 5, 0.01, StiffMask), twinIntegrator(300, 5, 0.01, StiffMask);
    integrator.setRandomNumberSeed(23);
    twinIntegrator.setRandomNumberSeed(23);
    Context context(*system, integrator, platform(), properties()),
        twin(*system, twinIntegrator, platform(), properties());
    setUp(integrator, context);
    setUp(twinIntegrator, twin);

    FlavorIntegrator flavor(0.01, 0.001, StiffMask);
    Context flavorContext(*system, flavor, platform(), properties());
    flavorContext.setPositions(fpuPositions({0.5, 0, 0}, {0.01, 0, 0}));
    flavor.step(2);
    StochasticImpulseIntegrator other(300, 1, 0.02, StiffMask);
    other.setRandomNumberSeed(99);
    Context otherContext(*system, other, platform(), properties());
    otherContext.setPositions(fpuPositions({0.2, 0.1, 0}, {0.03, 0, 0}));
    other.step(3);

    vector<ForeignCheckpoint> foreign = truncated(checkpointOf(otherContext), "StochasticImpulseIntegrator");
    foreign.push_back(
        {"VerletIntegrator's",
         verletCheckpoint(*system, platform(), properties()),
         {"StochasticImpulseIntegrator", "loadCheckpoint", "no data of this integrator", "VerletIntegrator"}});
    foreign.push_back({"FlavorIntegrator's",
                       checkpointOf(flavorContext),
                       {"StochasticImpulseIntegrator", "loadCheckpoint", "made with FlavorIntegrator"}});
    expectForeignCheckpointsRejected(context, stepFlavor, twin, stepFlavor, foreign);
}

TEST_P(IntegratorGuards, ImpulseIntegratesAParticleTetheredToAMasslessOneExactly) {
    // A HarmonicBondForce of length 0 and constant k between a fixed (massless) particle at a and a particle of mass
    // m: the massive one is the harmonic oscillator x(t) = a + (x0 - a) cos(w t) + v0/w sin(w t), w = sqrt(k/m).
    const double k = 1000.0, m = 12.0, h = 0.37;
    const int steps = 20;
    System system;
    system.addParticle(0.0);
    system.addParticle(m);
    HarmonicBondForce* bond = new HarmonicBondForce();
    bond->addBond(0, 1, 0.0, k);
    bond->setForceGroup(StiffGroup);
    system.addForce(bond);
    const Vec3 a(0.3, -0.2, 0.1), x0(0.5, 0.1, -0.15), v0(0.4, -0.3, 0.2);
    StochasticImpulseIntegrator integrator(0, 0, h, StiffMask);
    Context context(system, integrator, platform(), properties());
    context.setPositions({a, x0});
    // The massless particle is given a velocity: it must stay fixed anyway, as in OpenMM's own integrators.
    context.setVelocities({Vec3(1, 2, 3), v0});
    const double w = std::sqrt(k / m);
    vector<double> frequencies = integrator.getStiffModeFrequencies();
    ASSERT_EQ(3u, frequencies.size());
    for (double f : frequencies)
        EXPECT_NEAR(w, f, 1e-9 * w);
    integrator.step(steps);
    const double t = steps * h;
    vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
    const Vec3 expected = a + (x0 - a) * std::cos(w * t) + v0 * (std::sin(w * t) / w);
    const Vec3 expectedVelocity = (x0 - a) * (-w * std::sin(w * t)) + v0 * std::cos(w * t);
    for (int d = 0; d < 3; ++d) {
        EXPECT_EQ(a[d], q[0][d]);
        EXPECT_NEAR(expected[d], q[1][d], 1e-10);
        EXPECT_NEAR(expectedVelocity[d], v[1][d], 1e-9);
    }
}

TEST_P(IntegratorGuards, FlavorKeepsMasslessParticlesFixed) {
    System system;
    system.addParticle(0.0);
    system.addParticle(12.0);
    HarmonicBondForce* bond = new HarmonicBondForce();
    bond->addBond(0, 1, 0.0, 1000.0);
    bond->setForceGroup(StiffGroup);
    system.addForce(bond);
    CustomExternalForce* soft = new CustomExternalForce("x^2+y^2+z^2");
    soft->addParticle(0);
    soft->addParticle(1);
    soft->setForceGroup(SoftGroup);
    system.addForce(soft);
    const Vec3 a(0.3, -0.2, 0.1);
    for (double friction : {0.0, 2.0}) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        integrator.setFriction(friction);
        integrator.setTemperature(300);
        Context context(system, integrator, platform(), properties());
        context.setPositions({a, Vec3(0.5, 0.1, -0.15)});
        context.setVelocities({Vec3(1, 2, 3), Vec3(0.4, -0.3, 0.2)});
        integrator.step(50);
        const Vec3 q = positionsOf(context)[0];
        for (int d = 0; d < 3; ++d)
            EXPECT_EQ(a[d], q[d]) << "friction " << friction;
    }
}

TEST_P(IntegratorGuards, StiffGroupsOutsideTheIntegrationGroupsAreRejected) {
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    const vector<Vec3> positions = fpuPositions({1, 0, 0}, {0.02, 0, 0});
    const int softOnly = 1 << SoftGroup;
    const vector<string> fragments = {"integrationForceGroups = " + std::to_string(softOnly),
                                      "stiffGroups = " + std::to_string(StiffMask), "stiff group(s) {1}"};
    FlavorIntegrator flavor(0.01, 0.001, StiffMask);
    flavor.setIntegrationForceGroups(softOnly);
    expectRejected([&] { Context context(*system, flavor, platform()); }, fragments);
    StochasticImpulseIntegrator sim(0, 0, 0.01, StiffMask);
    sim.setIntegrationForceGroups(softOnly);
    expectRejected([&] { Context context(*system, sim, platform()); }, fragments);

    // Bound to a Context, the setter rejects the same and the Context runs on with the old groups.
    FlavorIntegrator boundFlavor(0.01, 0.001, StiffMask);
    StochasticImpulseIntegrator boundSim(0, 0, 0.01, StiffMask);
    for (Integrator* integrator : vector<Integrator*>{&boundFlavor, &boundSim}) {
        Context context(*system, *integrator, platform());
        context.setPositions(positions);
        expectRejected([&] { integrator->setIntegrationForceGroups(softOnly); }, fragments);
        EXPECT_EQ(-1, integrator->getIntegrationForceGroups());
        integrator->step(3);
        EXPECT_EQ(3, context.getStepCount());
    }
    boundFlavor.setIntegrationForceGroups(softOnly | StiffMask);
    EXPECT_EQ(softOnly | StiffMask, boundFlavor.getIntegrationForceGroups());
}

TEST_P(IntegratorGuards, FlavorWithoutSoftForceIsRejectedAtContextCreation) {
    // FlavorIntegrator(delta, tau, 1) makes group 0 stiff: every force of a System whose forces are all in group 0.
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    for (int i = 0; i < system->getNumForces(); ++i)
        system->getForce(i).setForceGroup(0);
    FlavorIntegrator flavor(0.01, 0.001, 1);
    expectRejected([&] { Context context(*system, flavor, platform()); },
                   {"stiffGroups = 1", "no force of the System is soft", "bitmask", "{1} means group 1"});
    // SIM without soft forces is the exact stiff flow and stays allowed: see
    // ImpulseIntegratesAParticleTetheredToAMasslessOneExactly.
}

TEST(IntegratorInput, RepeatedFrictionParticlesAreRejected) {
    FlavorIntegrator integrator(0.01, 0.001, StiffMask);
    integrator.setFrictionParticles({4, 0, 7});
    expectRejected([&] { integrator.setFrictionParticles({3, 1, 3}); }, {"frictionParticles", "3", "more than once"});
    expectRejected([&] { integrator.setFrictionParticles({-2}); }, {"frictionParticles", "-2", ">= 0"});
    EXPECT_EQ((vector<int>{4, 0, 7}), integrator.getFrictionParticles());
}

TEST_P(IntegratorGuards, ImpulseRejectsNonlinearStiffForcesFastNamingTheNonlinearity) {
    // 300 bent triatomic molecules whose bonds (rest length 0.1 nm) are the stiff group: not quadratic.  The
    // rejection must come from a few evaluations of the stiff group (not one per probed coordinate) and report the
    // nonlinearity, not a symptom of it.
    const int molecules = 300;
    System system;
    HarmonicBondForce* bonds = new HarmonicBondForce();
    bonds->setForceGroup(StiffGroup);
    CountingForce* counter = new CountingForce();
    counter->setForceGroup(StiffGroup);
    CustomExternalForce* soft = new CustomExternalForce("x^2+y^2+z^2");
    soft->setForceGroup(SoftGroup);
    vector<Vec3> positions;
    std::mt19937 generator(5);
    std::uniform_real_distribution<double> jitter(-0.01, 0.01);
    for (int i = 0; i < molecules; ++i) {
        const Vec3 origin(0.5 * (i % 10), 0.5 * ((i / 10) % 10), 0.5 * (i / 100));
        for (int a = 0; a < 3; ++a) {
            system.addParticle(a == 0 ? 16.0 : 1.0);
            soft->addParticle(3 * i + a);
        }
        positions.push_back(origin);
        positions.push_back(origin + Vec3(0.1 + jitter(generator), jitter(generator), 0));
        positions.push_back(origin + Vec3(-0.03, 0.095 + jitter(generator), jitter(generator)));
        bonds->addBond(3 * i, 3 * i + 1, 0.1, 4e5);
        bonds->addBond(3 * i, 3 * i + 2, 0.1, 4e5);
    }
    system.addForce(bonds);
    system.addForce(counter);
    system.addForce(soft);
    StochasticImpulseIntegrator integrator(300, 1, 0.002, StiffMask);
    Context context(system, integrator, platform());
    context.setPositions(positions);
    try {
        integrator.getStiffModeFrequencies();
        ADD_FAILURE() << "a nonlinear stiff group was accepted";
    } catch (const OpenMMException& e) {
        const string message = e.what();
        EXPECT_NE(string::npos, message.find("not quadratic")) << message;
        EXPECT_NE(string::npos, message.find("not linear")) << message;
        EXPECT_EQ(string::npos, message.find("symmetric")) << message;
    }
    // F(q) and three displaced evaluations.
    EXPECT_LE(counter->getCount(), 4);
}

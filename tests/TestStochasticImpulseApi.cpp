// Rejections, stiff-mode spectrum, re-measurement when the stiff potential changes, serialization, checkpoints.

#include "ExpectRejected.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/OpenMMException.h"
#include "openmm/VirtualSite.h"
#include "openmm/serialization/XmlSerializer.h"
#include <cmath>
#include <functional>
#include <memory>
#include <sstream>
#include <string>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::string;
using std::vector;

class ImpulseApi : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseApi);

namespace {

/** Two particles (masses m1, m2) joined by a stiff HarmonicBondForce of length r0, and a soft tether on each. */
System* springPair(double k, double r0, double m1 = 1.0, double m2 = 2.0) {
    System* system = new System();
    system->addParticle(m1);
    system->addParticle(m2);
    HarmonicBondForce* bond = new HarmonicBondForce();
    bond->addBond(0, 1, r0, k);
    bond->setForceGroup(StiffGroup);
    CustomExternalForce* tether = new CustomExternalForce("x^2+y^2+z^2");
    tether->addParticle(0);
    tether->addParticle(1);
    system->addForce(bond);
    system->addForce(tether);
    return system;
}

} // namespace

TEST(ImpulseInput, BadParametersAreRejectedNamingThem) {
    expectRejected([] { StochasticImpulseIntegrator(-1, 1, 0.01, 2); }, {"temperature", "-1", ">= 0"});
    expectRejected([] { StochasticImpulseIntegrator(300, -2, 0.01, 2); }, {"friction", "-2", ">= 0"});
    expectRejected([] { StochasticImpulseIntegrator(300, 1, 0, 2); }, {"stepSize", "= 0", "> 0"});
    expectRejected([] { StochasticImpulseIntegrator(300, 1, 0.01, 0); }, {"stiffGroups", "= 0"});
    StochasticImpulseIntegrator integrator(300, 1, 0.01, 2);
    expectRejected([&] { integrator.setSplitting(StochasticImpulseIntegrator::Yoshida4); },
                   {"splitting", "Yoshida4", "friction 0"});
    EXPECT_EQ(StochasticImpulseIntegrator::Strang, integrator.getSplitting());
    integrator.setFriction(0);
    integrator.setSplitting(StochasticImpulseIntegrator::Yoshida4);
    expectRejected([&] { integrator.setFriction(1); }, {"friction", "1", "Yoshida4"});
    EXPECT_EQ(0.0, integrator.getFriction());
}

TEST_P(ImpulseApi, StiffModeFrequenciesAreTheSpectrum) {
    // One spring k between masses 1 and 2: three zero modes (translation) and three at sqrt(k/mu).
    const double k = 3e4, mu = 2.0 / 3.0;
    std::unique_ptr<System> system(springPair(k, 0.0));
    StochasticImpulseIntegrator integrator(300, 1, 0.01, StiffMask);
    expectRejected([&] { integrator.getStiffModeFrequencies(); }, {"Context"});
    Context context(*system, integrator, platform(), properties());
    context.setPositions({Vec3(0, 0, 0), Vec3(0.1, 0.2, -0.1)});
    vector<double> omega = integrator.getStiffModeFrequencies();
    ASSERT_EQ(6u, omega.size());
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(0.0, omega[i]);
        EXPECT_NEAR(std::sqrt(k / mu), omega[3 + i], 1e-10 * std::sqrt(k / mu));
    }
}

TEST_P(ImpulseApi, ChangesToTheStiffPotentialAreMeasuredAgain) {
    System system;
    system.addParticle(1.0);
    system.addParticle(1.0);
    CustomExternalForce* stiff = new CustomExternalForce("0.5*k*(x^2+y^2+z^2)");
    stiff->addGlobalParameter("k", 100.0);
    stiff->addParticle(0);
    stiff->setForceGroup(StiffGroup);
    CustomExternalForce* perParticle = new CustomExternalForce("0.5*kp*(x^2+y^2+z^2)");
    perParticle->addPerParticleParameter("kp");
    perParticle->addParticle(1, {1.0});
    perParticle->setForceGroup(StiffGroup);
    system.addForce(stiff);
    system.addForce(perParticle);
    StochasticImpulseIntegrator integrator(0, 0, 0.01, StiffMask);
    Context context(system, integrator, platform(), properties());
    context.setPositions({Vec3(0.1, 0, 0), Vec3(0, 0.2, 0)});
    // OpenCL's fixed-point forces (2^-32 kJ/mol/nm) leave the measured frequencies 1.6e-9 off (PoCL).
    const double tolerance = isGpu() ? 5e-9 : 1e-9;
    integrator.step(1);
    EXPECT_NEAR(10.0, integrator.getStiffModeFrequencies().back(), tolerance);
    // A context parameter used by a stiff force.
    context.setParameter("k", 400.0);
    EXPECT_NEAR(20.0, integrator.getStiffModeFrequencies().back(), tolerance);
    // A force's updateParametersInContext(): the second particle's spring becomes the stiffest.
    perParticle->setParticleParameters(0, 1, {900.0});
    perParticle->updateParametersInContext(context);
    integrator.step(1);
    EXPECT_NEAR(30.0, integrator.getStiffModeFrequencies().back(), tolerance);
    // The explicit call (after a change the integrator is told about anyway, it must agree).
    integrator.updateStiffModes();
    EXPECT_NEAR(30.0, integrator.getStiffModeFrequencies().back(), tolerance);
}

TEST_P(ImpulseApi, NonquadraticStiffForcesNegativeCurvatureAndConstraintsAreRejected) {
    // A bond of nonzero length is not quadratic in the positions.
    std::unique_ptr<System> nonlinear(springPair(1e4, 0.1));
    StochasticImpulseIntegrator integrator(300, 1, 0.01, StiffMask);
    Context context(*nonlinear, integrator, platform(), properties());
    context.setPositions({Vec3(0, 0, 0), Vec3(0.12, 0.01, 0)});
    expectRejected([&] { integrator.step(1); }, {"not quadratic in the positions", "allowed", "FlavorIntegrator"});
    // Far from its rest length the bond is nearly linear, but not quite: still rejected.
    context.setPositions({Vec3(0, 0, 0), Vec3(3.0, 0.2, 0)});
    expectRejected([&] { integrator.step(1); }, {"not quadratic in the positions", "FlavorIntegrator"});

    // Negative curvature, reported with its value: k = -50 on a unit mass gives omega^2 = -50.
    System inverted;
    inverted.addParticle(1.0);
    CustomExternalForce* hill = new CustomExternalForce("-25*(x^2+y^2+z^2)");
    hill->addParticle(0);
    hill->setForceGroup(StiffGroup);
    inverted.addForce(hill);
    StochasticImpulseIntegrator second(300, 1, 0.01, StiffMask);
    Context invertedContext(inverted, second, platform(), properties());
    invertedContext.setPositions({Vec3(0.1, 0, 0)});
    // On OpenCL its fixed-point forces make it -49.99999993 (PoCL).
    try {
        second.step(1);
        ADD_FAILURE() << "no exception for negative curvature";
    } catch (const OpenMMException& e) {
        const string message = e.what();
        EXPECT_NE(string::npos, message.find("negative curvature")) << message;
        const size_t at = message.find("omega^2 = ");
        ASSERT_NE(string::npos, at) << message;
        EXPECT_NEAR(-50.0, std::stod(message.substr(at + 10)), isGpu() ? 1e-6 : 1e-12) << message;
    }

    // A constraint between two particles of one stiff component, at Context creation.
    std::unique_ptr<System> constrained(springPair(1e4, 0.0));
    constrained->addConstraint(1, 0, 0.2);
    StochasticImpulseIntegrator third(300, 1, 0.01, StiffMask);
    expectRejected([&] { Context c(*constrained, third, platform(), properties()); },
                   {"constraint 0", "particles 1 and 0", "joins two particles of one stiff component"});
    // Two particles of one stiff component, each constrained to another particle.
    std::unique_ptr<System> twice(springPair(1e4, 0.0));
    twice->addParticle(1.0);
    twice->addParticle(1.0);
    twice->addConstraint(0, 2, 0.2);
    twice->addConstraint(3, 1, 0.2);
    StochasticImpulseIntegrator fourth(300, 1, 0.01, StiffMask);
    expectRejected([&] { Context c(*twice, fourth, platform(), properties()); },
                   {"constraint 1", "particles 3 and 1", "particle 0", "at most one particle of each stiff component"});
}

TEST(ImpulseSerialization, XmlRoundTripKeepsEveryParameter) {
    StochasticImpulseIntegrator integrator(310, 0.0, 0.004, (1 << 3) | (1 << 31));
    integrator.setSplitting(StochasticImpulseIntegrator::Yoshida4);
    integrator.setRandomNumberSeed(-3);
    integrator.setConstraintTolerance(2e-7);
    integrator.setIntegrationForceGroups(0x00FF);
    std::stringstream buffer;
    XmlSerializer::serialize<Integrator>(&integrator, "Integrator", buffer);
    std::unique_ptr<Integrator> copy(XmlSerializer::deserialize<Integrator>(buffer));
    auto* sim = dynamic_cast<StochasticImpulseIntegrator*>(copy.get());
    ASSERT_NE(nullptr, sim);
    EXPECT_EQ(310.0, sim->getTemperature());
    EXPECT_EQ(0.0, sim->getFriction());
    EXPECT_EQ(0.004, sim->getStepSize());
    EXPECT_EQ((1 << 3) | (1 << 31), sim->getStiffGroups());
    EXPECT_EQ(StochasticImpulseIntegrator::Yoshida4, sim->getSplitting());
    EXPECT_EQ(-3, sim->getRandomNumberSeed());
    EXPECT_EQ(2e-7, sim->getConstraintTolerance());
    EXPECT_EQ(0x00FF, sim->getIntegrationForceGroups());
}

TEST_P(ImpulseApi, CheckpointsContinueIdentically) {
    std::unique_ptr<System> system(fpuSystem(3, 100.0));
    StochasticImpulseIntegrator integrator(300, 2.0, 0.01, StiffMask);
    integrator.setRandomNumberSeed(5);
    Context context(*system, integrator, platform(), properties());
    context.setPositions(fpuPositions({1, 0, 0}, {0.01, 0, 0}));
    integrator.step(5);
    std::stringstream checkpoint;
    context.createCheckpoint(checkpoint);
    integrator.step(10);
    vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
    context.loadCheckpoint(checkpoint);
    integrator.step(10);
    EXPECT_EQ(0.0, relativeDifference(positionsOf(context), q));
    EXPECT_EQ(0.0, relativeDifference(velocitiesOf(context), v));
}

TEST_P(ImpulseApi, ConstraintsOutsideStiffComponentsAndVirtualSitesWork) {
    // A stiff spring pair (particles 0, 1), a constrained diatomic (2, 3) held by soft tethers, and a virtual site
    // (4) at the diatomic's midpoint.
    System system;
    for (double m : {1.0, 2.0, 1.0, 3.0, 0.0})
        system.addParticle(m);
    system.setVirtualSite(4, new TwoParticleAverageSite(2, 3, 0.5, 0.5));
    system.addConstraint(2, 3, 0.15);
    HarmonicBondForce* stiff = new HarmonicBondForce();
    stiff->addBond(0, 1, 0.0, 1e5);
    stiff->setForceGroup(StiffGroup);
    CustomExternalForce* soft = new CustomExternalForce("0.5*(x^2+y^2+z^2)");
    for (int i = 0; i < 4; ++i)
        soft->addParticle(i);
    system.addForce(stiff);
    system.addForce(soft);
    StochasticImpulseIntegrator integrator(300, 2.0, 0.005, StiffMask);
    integrator.setConstraintTolerance(1e-8);
    integrator.setRandomNumberSeed(3);
    Context context(system, integrator, platform(), properties());
    context.setPositions({Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(0.3, 0, 0), Vec3(0.45, 0, 0), Vec3()});
    context.applyConstraints(1e-8);
    for (int block = 0; block < 20; ++block) {
        integrator.step(10);
        State state = context.getState(State::Positions | State::Velocities);
        const vector<Vec3>& q = state.getPositions();
        const vector<Vec3>& v = state.getVelocities();
        Vec3 bond = q[3] - q[2];
        EXPECT_NEAR(0.15, std::sqrt(bond.dot(bond)), 1e-7);
        EXPECT_NEAR(0.0, bond.dot(v[3] - v[2]), 1e-6);
        Vec3 site = (q[2] + q[3]) * 0.5 - q[4];
        EXPECT_NEAR(0.0, std::sqrt(site.dot(site)), 1e-12);
    }
}

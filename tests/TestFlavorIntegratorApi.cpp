// Bad input, serialization and checkpoints.

#include "ExpectRejected.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/OpenMMException.h"
#include "openmm/serialization/XmlSerializer.h"
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <sstream>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::string;
using std::vector;

class FlavorApi : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorApi);

namespace {

const double NaN = std::numeric_limits<double>::quiet_NaN();
const double Inf = std::numeric_limits<double>::infinity();

} // namespace

TEST(FlavorIntegratorInput, ConstructorRejectsBadParametersNamingThem) {
    expectRejected([] { FlavorIntegrator(0.0, 0.001, 2); }, {"mesoStep", "= 0", "> 0"});
    expectRejected([] { FlavorIntegrator(-1.0, 0.001, 2); }, {"mesoStep", "-1"});
    expectRejected([] { FlavorIntegrator(NaN, 0.001, 2); }, {"mesoStep", "nan", "finite"});
    expectRejected([] { FlavorIntegrator(0.01, 0.0, 2); }, {"microStep", "= 0", "> 0"});
    expectRejected([] { FlavorIntegrator(0.01, Inf, 2); }, {"microStep", "inf", "finite"});
    expectRejected([] { FlavorIntegrator(0.01, 0.02, 2); }, {"microStep", "0.02", "<= mesoStep (0.01 ps)"});
    expectRejected([] { FlavorIntegrator(0.01, 0.001, 0); }, {"stiffGroups", "= 0", "nonzero"});
    EXPECT_NO_THROW(FlavorIntegrator(0.01, 0.01, 2)); // tau = delta: the legacy integrator
}

TEST(FlavorIntegratorInput, RejectedSettersLeaveTheOldValue) {
    FlavorIntegrator integrator(0.01, 0.001, 2);
    expectRejected([&] { integrator.setMesoStep(0.0005); }, {"mesoStep", "0.0005", ">= microStep (0.001 ps)"});
    expectRejected([&] { integrator.setStepSize(-0.1); }, {"mesoStep", "-0.1"});
    expectRejected([&] { integrator.setMicroStep(0.1); }, {"microStep", "0.1", "<= mesoStep (0.01 ps)"});
    expectRejected([&] { integrator.setTemperature(-5); }, {"temperature", "-5", ">= 0", "K"});
    expectRejected([&] { integrator.setTemperature(NaN); }, {"temperature", "nan"});
    expectRejected([&] { integrator.setFriction(-1); }, {"friction", "-1", ">= 0", "1/ps"});
    expectRejected([&] { integrator.setStiffGroups(0); }, {"stiffGroups", "0"});
    expectRejected([&] { integrator.setScheme((FlavorIntegrator::Scheme)7); }, {"scheme", "7"});
    expectRejected([&] { integrator.setAveraging((FlavorIntegrator::Averaging)3); },
                   {"averaging", "3", "Nonintrusive (0)", "ArtificialProjected (2)"});
    expectRejected([&] { integrator.setFrictionParticles({0, -2}); }, {"frictionParticles", "-2", ">= 0"});
    EXPECT_TRUE(integrator.getFrictionParticles().empty());
    EXPECT_EQ(0.01, integrator.getMesoStep());
    EXPECT_EQ(0.001, integrator.getMicroStep());
    EXPECT_EQ(0.0, integrator.getTemperature());
    EXPECT_EQ(0.0, integrator.getFriction());
    EXPECT_EQ(2, integrator.getStiffGroups());
    EXPECT_EQ(FlavorIntegrator::Verlet, integrator.getScheme());
    EXPECT_EQ(FlavorIntegrator::Nonintrusive, integrator.getAveraging());
    EXPECT_FALSE(integrator.getExactFastFlow());
}

TEST_P(FlavorApi, ASystemWithoutStiffForcesIsRejectedAndTheContextStaysUsable) {
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    FlavorIntegrator wrongGroups(0.01, 0.001, 1 << 7);
    expectRejected([&] { Context context(*system, wrongGroups, platform(), properties()); },
                   {"stiffGroups", "128", "no force in these groups"});

    FlavorIntegrator integrator(0.01, 0.001, StiffMask);
    Context context(*system, integrator, platform(), properties());
    vector<Vec3> q0 = fpuPositions({1, 0, 0}, {0.02, 0, 0});
    context.setPositions(q0);
    integrator.step(5);
    expectRejected([&] { integrator.setStiffGroups(1 << 9); }, {"stiffGroups", "512"});
    expectRejected([&] { integrator.setMicroStep(1.0); }, {"microStep"});
    EXPECT_EQ(StiffMask, integrator.getStiffGroups());
    integrator.step(5);
    vector<Vec3> q = positionsOf(context);
    EXPECT_TRUE(std::isfinite(q[0][0]));
    EXPECT_GT(relativeDifference(q, q0), 1e-6);
}

TEST(FlavorIntegratorSerialization, XmlRoundTripKeepsEveryParameter) {
    FlavorIntegrator integrator(0.004, 0.0003, (1 << 2) | (1 << 31));
    integrator.setScheme(FlavorIntegrator::SymplecticEuler);
    integrator.setTemperature(310.5);
    integrator.setFriction(2.5);
    integrator.setStiffFriction(true);
    integrator.setRandomNumberSeed(-17);
    integrator.setConstraintTolerance(3e-7);
    integrator.setIntegrationForceGroups(0x0F0F);
    integrator.setFrictionParticles({4, 0, 7});
    integrator.setAveraging(FlavorIntegrator::Artificial);
    integrator.setExactFastFlow(true);
    std::stringstream buffer;
    XmlSerializer::serialize<Integrator>(&integrator, "Integrator", buffer);
    std::unique_ptr<Integrator> copy(XmlSerializer::deserialize<Integrator>(buffer));
    FlavorIntegrator* flavor = dynamic_cast<FlavorIntegrator*>(copy.get());
    ASSERT_NE(nullptr, flavor);
    EXPECT_EQ(0.004, flavor->getMesoStep());
    EXPECT_EQ(0.0003, flavor->getMicroStep());
    EXPECT_EQ((1 << 2) | (1 << 31), flavor->getStiffGroups());
    EXPECT_EQ(FlavorIntegrator::SymplecticEuler, flavor->getScheme());
    EXPECT_EQ(310.5, flavor->getTemperature());
    EXPECT_EQ(2.5, flavor->getFriction());
    EXPECT_TRUE(flavor->getStiffFriction());
    EXPECT_EQ(-17, flavor->getRandomNumberSeed());
    EXPECT_EQ(3e-7, flavor->getConstraintTolerance());
    EXPECT_EQ(0x0F0F, flavor->getIntegrationForceGroups());
    EXPECT_EQ((vector<int>{4, 0, 7}), flavor->getFrictionParticles());
    EXPECT_EQ(FlavorIntegrator::Artificial, flavor->getAveraging());
    EXPECT_TRUE(flavor->getExactFastFlow());
}

TEST_P(FlavorApi, CheckpointsContinueIdentically) {
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    for (double friction : {0.0, 5.0}) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        integrator.setFriction(friction);
        integrator.setTemperature(300);
        integrator.setRandomNumberSeed(42);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        integrator.step(7);
        std::stringstream checkpoint;
        context.createCheckpoint(checkpoint);
        integrator.step(13);
        vector<Vec3> q1 = positionsOf(context), v1 = velocitiesOf(context);
        context.loadCheckpoint(checkpoint);
        integrator.step(13);
        EXPECT_EQ(0.0, relativeDifference(positionsOf(context), q1)) << "friction " << friction;
        EXPECT_EQ(0.0, relativeDifference(velocitiesOf(context), v1)) << "friction " << friction;
        EXPECT_EQ(20, context.getStepCount());
    }
}

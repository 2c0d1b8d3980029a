// The Warped friction scaling (setWarpedFrictionScaling): on stiff modes of one frequency it is the integrator with
// that frequency's scaled friction, it does change the dynamics, and it is checked, described and serialized.

#include "DrudeWater.h"
#include "ExpectRejected.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "internal/ExactModeFlow.h"
#include "openmm/Context.h"
#include "openmm/serialization/XmlSerializer.h"
#include <cmath>
#include <memory>
#include <sstream>
#include <string>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseFrictionScaling : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseFrictionScaling);

namespace {

constexpr double StiffFriction = 20.0;

/**
 * The friction scale s of a mode of frequency omega at step h: the root of s = (2 sin(omega~ h/2)/(omega h))^2 with
 * omega~ the (phase limited) warped frequency at friction StiffFriction s, found by bisection on (0, 1].
 */
double frictionScale(double omega, double h, double maxPhase) {
    auto excess = [&](double s) {
        const double flow = phaseLimitedFrequency(warpedFrequency(omega, StiffFriction * s, h), h, maxPhase);
        return s - std::pow(2 * std::sin(0.5 * flow * h) / (omega * h), 2);
    };
    double lo = 1e-6, hi = 1.0;
    for (int i = 0; i < 100; ++i)
        (excess(0.5 * (lo + hi)) < 0 ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
}

/** Positions and velocities after steps of a Warped SIM (cold stiff modes) on the Drude waters. */
std::pair<vector<Vec3>, vector<Vec3>> warpedRun(const DrudeWater& water, double h, double maxPhase,
                                                StochasticImpulseIntegrator::ThermostatPlacement placement,
                                                double stiffFriction, bool scaled, Platform& platform,
                                                const std::map<std::string, std::string>& properties) {
    StochasticImpulseIntegrator integrator(300.0, 5.0, h, StiffMask);
    integrator.setSplitting(StochasticImpulseIntegrator::Warped);
    integrator.setThermostatPlacement(placement);
    integrator.setMaxWarpedPhase(maxPhase);
    integrator.setStiffModeTemperature(1.0);
    integrator.setStiffModeFriction(stiffFriction);
    integrator.setWarpedFrictionScaling(scaled);
    integrator.setRandomNumberSeed(5);
    Context context(water.system, integrator, platform, properties);
    context.setPositions(water.positions);
    context.setVelocitiesToTemperature(300.0, 2);
    integrator.step(60);
    return {positionsOf(context), velocitiesOf(context)};
}

} // namespace

TEST_P(ImpulseFrictionScaling, OnModesOfOneFrequencyItIsThatFrequencysScaledFriction) {
    // Rigid Drude waters (every Drude pair has omega = 1036/ps): scaling on with the stiff friction 20/ps follows the
    // same trajectory as scaling off with 20 s/ps, s found here by its own bisection, at 2 fs (Warped's own phase)
    // and at 3 fs with the phase limit 2.05, with both placements of the zero modes' thermostat.  Scaling off at
    // 20/ps is a different trajectory.
    const DrudeWater water(8, false);
    const double coreMass = OxygenMass - DrudeMass, mu = coreMass * DrudeMass / OxygenMass;
    const double omega = std::sqrt(DrudeK / mu);
    for (auto [h, maxPhase] : {std::pair<double, double>{0.002, 0.0}, {0.003, 2.05}}) {
        for (auto placement : {StochasticImpulseIntegrator::Throughout, StochasticImpulseIntegrator::Middle}) {
            SCOPED_TRACE("H = " + std::to_string(h) + ", placement " + std::to_string((int)placement));
            const double s = frictionScale(omega, h, maxPhase);
            EXPECT_LT(s, 0.6);
            const auto scaled = warpedRun(water, h, maxPhase, placement, StiffFriction, true, platform(), properties());
            const auto reduced =
                warpedRun(water, h, maxPhase, placement, StiffFriction * s, false, platform(), properties());
            const auto unscaled =
                warpedRun(water, h, maxPhase, placement, StiffFriction, false, platform(), properties());
            EXPECT_LT(relativeDifference(scaled.first, reduced.first), 1e-10);
            EXPECT_LT(relativeDifference(scaled.second, reduced.second), 1e-9);
            EXPECT_GT(relativeDifference(scaled.second, unscaled.second), 1e-4);
        }
    }
}

TEST_P(ImpulseFrictionScaling, IsCheckedDescribedAndSerialized) {
    const DrudeWater water(2, false);
    StochasticImpulseIntegrator integrator(300.0, 5.0, 0.002, StiffMask);
    integrator.setStiffModeTemperature(1.0);
    integrator.setStiffModeFriction(StiffFriction);
    EXPECT_FALSE(integrator.getWarpedFrictionScaling());
    integrator.setWarpedFrictionScaling(true);
    EXPECT_TRUE(integrator.getWarpedFrictionScaling());
    // Only Warped has warped modes: another splitting is rejected when a step is taken, and the Context takes steps
    // once the splitting is Warped.
    Context context(water.system, integrator, platform(), properties());
    context.setPositions(water.positions);
    expectRejected([&] { integrator.step(1); }, {"warpedFrictionScaling = true", "splitting = 1", "Warped (4)"});
    EXPECT_EQ(0, context.getState(State::Positions).getStepCount());
    integrator.setSplitting(StochasticImpulseIntegrator::Warped);
    integrator.step(2);
    EXPECT_EQ(2, context.getState(State::Positions).getStepCount());
    EXPECT_NE(std::string::npos, integrator.describeStep().find("stiff friction scaled")) << integrator.describeStep();
    std::stringstream buffer;
    XmlSerializer::serialize<Integrator>(&integrator, "Integrator", buffer);
    EXPECT_NE(std::string::npos, buffer.str().find("warpedFrictionScaling=\"1\"")) << buffer.str();
    std::unique_ptr<Integrator> copy(XmlSerializer::deserialize<Integrator>(buffer));
    EXPECT_TRUE(dynamic_cast<StochasticImpulseIntegrator&>(*copy).getWarpedFrictionScaling());
    // Off, the document is the one older versions read.
    integrator.setWarpedFrictionScaling(false);
    std::stringstream plain;
    XmlSerializer::serialize<Integrator>(&integrator, "Integrator", plain);
    EXPECT_EQ(std::string::npos, plain.str().find("warpedFrictionScaling")) << plain.str();
    EXPECT_NE(std::string::npos, plain.str().find("version=\"3\"")) << plain.str();
}

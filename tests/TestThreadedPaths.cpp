// The CPU platform's thread pool runs a pass only when it has more than 1024 items per thread, so the small systems
// of the other tests run every pass on the calling thread.  Here 1,000 FPU chains give 6,000 particles (particle
// passes, thermostats) and 3,000 stiff components (the exact stiff flow and its noise), well above 2 x 1024: with two
// threads every pass is split.  Random numbers are counter-based per (stream, particle), so the trajectory must not
// depend on the number of threads at all, and must match the Reference platform's serial loops.

#include "FlavorIntegrator.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/Platform.h"
#include <functional>
#include <gtest/gtest.h>
#include <map>
#include <memory>
#include <string>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;

namespace {

constexpr int Chains = 1000;

struct Trajectory {
    std::vector<Vec3> positions, velocities;
};

/** Runs 20 steps of a fresh integrator on the chains and returns the final state. */
Trajectory run(const std::function<Integrator*()>& makeIntegrator, const std::string& platformName, int threads) {
    std::unique_ptr<System> system(fpuSystem(3, 50.0, Chains));
    std::unique_ptr<Integrator> integrator(makeIntegrator());
    std::map<std::string, std::string> properties;
    if (threads > 0)
        properties["Threads"] = std::to_string(threads);
    Context context(*system, *integrator, Platform::getPlatformByName(platformName), properties);
    std::vector<Vec3> positions = fpuPositions({1, 0.2, -0.4}, {0.02, -0.01, 0.01}, Chains);
    // Distinct chains: a different velocity on each particle.
    std::vector<Vec3> velocities(positions.size());
    for (size_t i = 0; i < velocities.size(); ++i)
        velocities[i] = Vec3(0.3 * std::sin(0.7 * i), 0, 0);
    context.setPositions(positions);
    context.setVelocities(velocities);
    integrator->step(20);
    return {positionsOf(context), velocitiesOf(context)};
}

void expectThreadIndependent(const std::function<Integrator*()>& makeIntegrator) {
    const Trajectory reference = run(makeIntegrator, "Reference", 0);
    const Trajectory oneThread = run(makeIntegrator, "CPU", 1);
    const Trajectory twoThreads = run(makeIntegrator, "CPU", 2);
    // The same work, split differently: bit for bit.
    EXPECT_EQ(oneThread.positions, twoThreads.positions);
    EXPECT_EQ(oneThread.velocities, twoThreads.velocities);
    // The CPU platform computes these forces with the Reference code; only our passes are threaded.
    EXPECT_LT(relativeDifference(twoThreads.positions, reference.positions), 1e-12);
    EXPECT_LT(relativeDifference(twoThreads.velocities, reference.velocities), 1e-12);
}

} // namespace

TEST(ThreadedPaths, LangevinFlavorIsThreadIndependent) {
    expectThreadIndependent([] {
        FlavorIntegrator* integrator = new FlavorIntegrator(0.01, 0.002, StiffMask);
        integrator->setTemperature(300);
        integrator->setFriction(5.0);
        integrator->setRandomNumberSeed(11);
        return integrator;
    });
}

TEST(ThreadedPaths, LangevinStochasticImpulseIsThreadIndependent) {
    expectThreadIndependent([] {
        StochasticImpulseIntegrator* integrator = new StochasticImpulseIntegrator(300, 5.0, 0.01, StiffMask);
        integrator->setRandomNumberSeed(11);
        return integrator;
    });
}

// The CPU platform's thread pool runs a pass only when it has more than 1024 items per thread, so the small systems
// of the other tests run every pass on the calling thread.  Here 1,000 FPU chains give 6,000 particles (particle
// passes, thermostats) and 3,000 stiff components (the exact stiff flow and its noise), well above 2 x 1024: with two
// threads every pass is split.  Random numbers are counter-based per (stream, particle), so the trajectory must not
// depend on the number of threads at all, and must match the Reference platform's serial loops.  The artificial
// FLAVOR's frozen stage is threaded by clusters (one at a time to whichever thread is free) and chunks of rigid water:
// its test below has enough of both to be split.

#include "FlavorIntegrator.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
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

/**
 * 800 flexible bent molecules with frozen bonds and angles (800 clusters, 2,400 frozen distances) and 400 rigid
 * waters (chunks for SETTLE) on soft tethers: 20 steps of the Langevin ArtificialProjected FLAVOR.
 */
Trajectory runFrozenStage(const std::string& platformName, int threads) {
    const int molecules = 800, waters = 400;
    System system;
    for (int m = 0; m < molecules + waters; ++m)
        for (double mass : {15.999, 1.008, 1.008})
            system.addParticle(mass);
    addStiffBentMolecules(system, 0, molecules);
    for (int w = 0; w < waters; ++w) {
        const int o = 3 * (molecules + w);
        system.addConstraint(o, o + 1, 0.09572);
        system.addConstraint(o, o + 2, 0.09572);
        system.addConstraint(o + 1, o + 2, 0.15139);
    }
    CustomExternalForce* tether = new CustomExternalForce("200*((x-x0)^2+(y-y0)^2+(z-z0)^2)");
    tether->addPerParticleParameter("x0");
    tether->addPerParticleParameter("y0");
    tether->addPerParticleParameter("z0");
    std::vector<Vec3> positions, velocities;
    for (int m = 0; m < molecules + waters; ++m) {
        const Vec3 centre(0.5 * (m % 10), 0.5 * ((m / 10) % 10), 0.5 * (m / 100));
        const std::vector<Vec3> molecule =
            m >= molecules ? std::vector<Vec3>{centre, centre + Vec3(0.09572, 0, 0), centre + Vec3(-0.0240, 0.0927, 0)}
                           : bentMoleculePositions(centre);
        positions.insert(positions.end(), molecule.begin(), molecule.end());
        for (int k = 0; k < 3; ++k) {
            const int i = 3 * m + k;
            tether->addParticle(i, {centre[0], centre[1], centre[2]});
            velocities.push_back(Vec3(std::sin(0.7 * i), std::cos(1.3 * i), std::sin(2.1 * i)) * 0.8);
        }
    }
    tether->setForceGroup(SoftGroup);
    system.addForce(tether);
    FlavorIntegrator integrator(0.004, 0.001, StiffMask);
    integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
    integrator.setTemperature(300);
    integrator.setFriction(5.0);
    integrator.setRandomNumberSeed(11);
    std::map<std::string, std::string> properties;
    if (threads > 0)
        properties["Threads"] = std::to_string(threads);
    Context context(system, integrator, Platform::getPlatformByName(platformName), properties);
    context.setPositions(positions);
    context.setVelocities(velocities);
    context.applyConstraints(1e-10);
    context.applyVelocityConstraints(1e-10);
    integrator.step(20);
    return {positionsOf(context), velocitiesOf(context)};
}

void expectSameTrajectories(const Trajectory& reference, const Trajectory& oneThread, const Trajectory& twoThreads) {
    // The same work, split differently: bit for bit.
    EXPECT_EQ(oneThread.positions, twoThreads.positions);
    EXPECT_EQ(oneThread.velocities, twoThreads.velocities);
    // The CPU platform computes these forces with the Reference code; only our passes are threaded.
    EXPECT_LT(relativeDifference(twoThreads.positions, reference.positions), 1e-12);
    EXPECT_LT(relativeDifference(twoThreads.velocities, reference.velocities), 1e-12);
}

void expectThreadIndependent(const std::function<Integrator*()>& makeIntegrator) {
    expectSameTrajectories(run(makeIntegrator, "Reference", 0), run(makeIntegrator, "CPU", 1),
                           run(makeIntegrator, "CPU", 2));
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

TEST(ThreadedPaths, ArtificialFlavorFrozenStageIsThreadIndependent) {
    expectSameTrajectories(runFrozenStage("Reference", 0), runFrozenStage("CPU", 1), runFrozenStage("CPU", 2));
}

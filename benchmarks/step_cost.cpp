// Per-step costs of FlavorIntegrator and of the force evaluations it needs, timed in C++ so that no Python call
// overhead enters.  The force-evaluation cost is measured directly: an Integrator whose step() is one
// ContextImpl::calcForcesAndEnergy() call for the given force groups, which is exactly what FlavorIntegrator pays per
// evaluation (OpenMM's VerletIntegrator with restricted force groups adds its own update loop on top).
//
// The system is `chains` independent Fermi-Pasta-Ulam chains (FLAVORS paper eq. 6.7: stiff HarmonicBondForce in group
// 1, soft CustomBondForce "r^4" and walls CustomExternalForce "x^4" in group 0), spread along y; with --springs N it is
// N independent stiff springs (HarmonicBondForce of length 0, group 1) with a soft x^4 on every particle (group 0),
// the system whose stiff-mode set-up benchmarks/sim_work_precision.py times.
//
// Usage: step_cost [--platform Reference|CPU] [--chains N | --springs N] [--threads N] [--seconds S] [--repeats N]
//                  [--steps N] [--plugins DIR] [measurement ...]
// Measurements: force_soft force_stiff force_all flavor_verlet flavor_euler verlet verlet_soft verlet_stiff
// sim_strang sim_lietrotter sim_yoshida4 sim_strang_langevin (default: all but the last two).  Prints one JSON object:
// microseconds per step (minimum and median over the repeats).
// --steps N times exactly one batch of N steps after a 10-step warm-up, for instruction counting under callgrind
// (the difference of two runs with different N is the cost of those steps alone).

#include "FlavorIntegrator.h"
#include "FpuChain.h"
#include "OpenMM.h"
#include "StochasticImpulseIntegrator.h"
#include "openmm/internal/ContextImpl.h"
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

using namespace OpenMM;

namespace {

constexpr int SoftGroup = 0, StiffGroup = 1;
constexpr int M = 3;
constexpr double Omega = 200.0;

class ForceOnlyIntegrator : public Integrator {
public:
    explicit ForceOnlyIntegrator(int groups) : groups(groups) { setStepSize(1e-3); }
    void step(int steps) override {
        for (int i = 0; i < steps; ++i)
            context->calcForcesAndEnergy(true, false, groups);
    }

protected:
    void initialize(ContextImpl& impl) override {
        context = &impl;
        owner = &impl.getOwner();
    }
    std::vector<std::string> getKernelNames() override { return {}; }
    double computeKineticEnergy() override { return 0.0; }

private:
    int groups;
};

System* fpuChains(int chains) {
    return FlavorExamples::fpuSystem(M, Omega, chains);
}

System* independentSprings(int springs) {
    System* system = new System();
    HarmonicBondForce* stiff = new HarmonicBondForce();
    CustomExternalForce* soft = new CustomExternalForce("x^4");
    stiff->setForceGroup(StiffGroup);
    soft->setForceGroup(SoftGroup);
    for (int i = 0; i < springs; ++i) {
        system->addParticle(1.0);
        system->addParticle(1.0);
        stiff->addBond(2 * i, 2 * i + 1, 0.0, Omega * Omega / 2);
        soft->addParticle(2 * i);
        soft->addParticle(2 * i + 1);
    }
    system->addForce(stiff);
    system->addForce(soft);
    return system;
}

// Spring i at a random point of the cube [-1, 1]^3, stretched by up to 0.01 nm per coordinate.
std::vector<Vec3> springPositions(int springs) {
    std::mt19937 random(springs);
    std::uniform_real_distribution<double> box(-1.0, 1.0), stretch(-0.01, 0.01);
    std::vector<Vec3> positions;
    for (int i = 0; i < springs; ++i) {
        Vec3 first(box(random), box(random), box(random));
        positions.push_back(first);
        positions.push_back(first + Vec3(stretch(random), stretch(random), stretch(random)));
    }
    return positions;
}

// Chain 0 starts as in Fig. 6.5; the others at random slow and fast coordinates of the same size, so no two chains
// move in lockstep.  Chain c lies at y = c.
std::vector<Vec3> fpuPositions(int chains) {
    std::mt19937 random(1234);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    std::vector<Vec3> positions;
    const double s = std::sqrt(2.0);
    for (int c = 0; c < chains; ++c)
        for (int i = 0; i < M; ++i) {
            double x0 = (c == 0 ? (i == 0 ? 1.0 : 0.0) : 0.5 * uniform(random));
            double x1 = (c == 0 ? (i == 0 ? 1.0 : 0.0) : uniform(random)) / Omega;
            positions.push_back(Vec3((x0 - x1) / s, c, 0));
            positions.push_back(Vec3((x0 + x1) / s, c, 0));
        }
    return positions;
}

std::unique_ptr<Integrator> makeIntegrator(const std::string& name) {
    const double delta = 2e-3, tau = 1e-4, h = 1e-4;
    const int all = -1, soft = 1 << SoftGroup, stiff = 1 << StiffGroup;
    if (name == "force_soft")
        return std::make_unique<ForceOnlyIntegrator>(soft);
    if (name == "force_stiff")
        return std::make_unique<ForceOnlyIntegrator>(stiff);
    if (name == "force_all")
        return std::make_unique<ForceOnlyIntegrator>(all);
    if (name == "flavor_verlet" || name == "flavor_euler") {
        auto flavor = std::make_unique<FlavorPlugin::FlavorIntegrator>(delta, tau, stiff);
        flavor->setScheme(name == "flavor_verlet" ? FlavorPlugin::FlavorIntegrator::Verlet
                                                  : FlavorPlugin::FlavorIntegrator::SymplecticEuler);
        return flavor;
    }
    if (name == "verlet" || name == "verlet_soft" || name == "verlet_stiff") {
        auto verlet = std::make_unique<VerletIntegrator>(h);
        if (name != "verlet")
            verlet->setIntegrationForceGroups(name == "verlet_soft" ? soft : stiff);
        return verlet;
    }
    if (name == "sim_strang" || name == "sim_lietrotter" || name == "sim_yoshida4" || name == "sim_strang_langevin") {
        const bool langevin = (name == "sim_strang_langevin");
        auto sim = std::make_unique<FlavorPlugin::StochasticImpulseIntegrator>(langevin ? 300.0 : 0.0,
                                                                               langevin ? 1.0 : 0.0, 0.01, stiff);
        if (name == "sim_lietrotter")
            sim->setSplitting(FlavorPlugin::StochasticImpulseIntegrator::LieTrotter);
        if (name == "sim_yoshida4")
            sim->setSplitting(FlavorPlugin::StochasticImpulseIntegrator::Yoshida4);
        return sim;
    }
    return nullptr;
}

double seconds(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

} // namespace

int main(int argc, char** argv) {
    std::string platformName = "Reference", plugins = FLAVORS_PLUGIN_DIR;
    int chains = 1, springs = 0, threads = 0, repeats = 3;
    long long fixedSteps = 0;
    double target = 0.2;
    std::vector<std::string> names;
    for (int i = 1; i < argc; ++i) {
        std::string arg = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "%s needs a value\n", arg.c_str());
                std::exit(2);
            }
            return argv[++i];
        };
        if (arg == "--platform")
            platformName = value();
        else if (arg == "--chains")
            chains = std::atoi(value().c_str());
        else if (arg == "--springs")
            springs = std::atoi(value().c_str());
        else if (arg == "--threads")
            threads = std::atoi(value().c_str());
        else if (arg == "--seconds")
            target = std::atof(value().c_str());
        else if (arg == "--repeats")
            repeats = std::max(1, std::atoi(value().c_str()));
        else if (arg == "--steps")
            fixedSteps = std::atoll(value().c_str());
        else if (arg == "--plugins")
            plugins = value();
        else if (!arg.empty() && arg[0] == '-') {
            std::fprintf(stderr, "unknown option %s\n", arg.c_str());
            return 2;
        } else
            names.push_back(arg);
    }
    if (names.empty())
        names = {"force_soft", "force_stiff", "force_all",    "flavor_verlet", "flavor_euler",
                 "verlet",     "verlet_soft", "verlet_stiff", "sim_strang",    "sim_lietrotter"};

    Platform::loadPluginsFromDirectory(Platform::getDefaultPluginsDirectory());
    Platform::loadPluginsFromDirectory(plugins);
    Platform& platform = Platform::getPlatformByName(platformName);
    std::map<std::string, std::string> properties;
    if (threads > 0 && platformName == "CPU")
        properties["Threads"] = std::to_string(threads);

    std::unique_ptr<System> system(springs > 0 ? independentSprings(springs) : fpuChains(chains));
    std::vector<Vec3> positions = springs > 0 ? springPositions(springs) : fpuPositions(chains);
    std::printf("{\"platform\": \"%s\", \"chains\": %d, \"springs\": %d, \"particles\": %d, \"threads\": %d, "
                "\"results\": {",
                platformName.c_str(), springs > 0 ? 0 : chains, springs, system->getNumParticles(), threads);
    for (size_t k = 0; k < names.size(); ++k) {
        std::unique_ptr<Integrator> integrator = makeIntegrator(names[k]);
        if (!integrator) {
            std::fprintf(stderr, "unknown measurement %s\n", names[k].c_str());
            return 2;
        }
        Context context(*system, *integrator, platform, properties);
        context.setPositions(positions);
        context.setVelocities(std::vector<Vec3>(positions.size()));
        integrator->step(10);
        // Grow the batch until it takes a tenth of the target, then size the timed batches from it.
        long long n = 10;
        double elapsed = 0.0;
        if (fixedSteps > 0) {
            n = fixedSteps;
            repeats = 1;
        }
        while (fixedSteps == 0) {
            auto start = std::chrono::steady_clock::now();
            integrator->step((int)n);
            elapsed = seconds(start);
            if (elapsed > 0.1 * target || n > 100000000)
                break;
            n *= 4;
        }
        if (fixedSteps == 0)
            n = std::max(1LL, (long long)(n * target / elapsed));
        std::vector<double> perStep;
        for (int r = 0; r < repeats; ++r) {
            auto start = std::chrono::steady_clock::now();
            integrator->step((int)n);
            perStep.push_back(1e6 * seconds(start) / n);
        }
        std::sort(perStep.begin(), perStep.end());
        std::printf("%s\"%s\": {\"us_per_step_min\": %.6g, \"us_per_step_median\": %.6g, \"steps\": %lld}",
                    k == 0 ? "" : ", ", names[k].c_str(), perStep.front(), perStep[perStep.size() / 2], n);
        std::fflush(stdout);
        std::fprintf(stderr, "  [C++ %s] %s: %.4g us/step\n", platformName.c_str(), names[k].c_str(), perStep.front());
    }
    std::printf("}}\n");
    return 0;
}

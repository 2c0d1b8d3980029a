// The GPU backend (OpenMM's common compute platforms: OpenCL and CUDA) against the Reference platform: in double
// precision the same counter-based noise and the same arithmetic make every supported scheme follow the Reference
// trajectory to rounding, and every setting the backend does not have yet is rejected by name.  Each test runs once per
// GPU platform, skipped where OpenMM has no such platform (no OpenCL driver, no NVIDIA GPU) or this build has no
// backend for it.  The tolerances were measured on OpenCL (PoCL) in double precision, where both platforms run the
// same kernels with IEEE double arithmetic.  One Context per platform and integrator, reused for every setting of that
// integrator (PoCL compiles each program once per Context).

#include "FlavorIntegrator.h"
#include "OpenCLCallCounts.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/DrudeForce.h"
#include "openmm/DrudeLangevinIntegrator.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/LangevinMiddleIntegrator.h"
#include "openmm/NonbondedForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/State.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <algorithm>
#include <cmath>
#include <dlfcn.h>
#include <functional>
#include <gtest/gtest.h>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::string;
using std::vector;

namespace {

constexpr int Steps = 45;
/** nm: what double-precision rounding leaves after Steps steps of these small systems. */
constexpr double Tolerance = 1e-7;

/** Whether OpenMM has the GPU platform named and this build has its backend. */
bool haveBackend(const string& platform) {
    const vector<string> built = gpuPlatformsBuilt();
    if (std::find(built.begin(), built.end(), platform) == built.end())
        return false;
    try {
        Platform::getPlatformByName(platform);
        return true;
    } catch (const OpenMMException&) {
    }
    return false;
}

/** Two FPU chains (m = 3, omega = 50) moving in all three directions. */
struct FpuChains {
    std::unique_ptr<System> system{fpuSystem(3, 50.0, 2)};
    vector<Vec3> positions = fpuPositions({1, 0.2, -0.4}, {0.02, -0.01, 0.01}, 2), velocities;
    FpuChains() {
        for (size_t i = 0; i < positions.size(); ++i) {
            positions[i][2] = 0.02 * std::cos(0.9 * i);
            velocities.push_back(Vec3(0.2 * std::cos(0.4 * i), 0.1 * std::sin(1.7 * i), 0.07 * std::cos(1.1 * i)));
        }
    }
};

/**
 * SWM4-NDP-like waters with PME: each an oxygen core, two hydrogens and a Drude particle on a zero-length spring (the
 * stiff group), the M site's charge on the oxygen, on a 3 x 3 x 3 lattice in a 1.5 nm box; flexible (soft O-H bonds
 * and H-O-H angle) or rigid (O-H and H-H constraints, SWM4-NDP's geometry: the oxygen core is constrained, its
 * constraint impulses reaching its Drude particle through the pair's flow).  Small repulsive cores on the hydrogens and
 * Drude particles, which SWM4-NDP does not have, keep this dilute lattice from the polarization collapse of a hydrogen
 * onto another molecule's Drude particle (after about 175 steps without them).
 */
struct DrudeWaters {
    System system;
    vector<Vec3> positions, velocities;
    /** drudeForce: the springs in a DrudeForce (as OpenMM's Drude integrators need), else in a HarmonicBondForce. */
    explicit DrudeWaters(bool rigid = false, bool drudeForce = false) {
        const double oh = 0.09572, angle = rigid ? 2 * std::asin(0.5 * 0.15139 / oh) : 1.8242;
        // Rigid molecules start in their constrained geometry.
        const double tilt = rigid ? 0.0 : 0.01;
        HarmonicBondForce* drude = new HarmonicBondForce();
        drude->setForceGroup(StiffGroup);
        DrudeForce* drudeSprings = new DrudeForce();
        drudeSprings->setForceGroup(StiffGroup);
        HarmonicBondForce* bonds = new HarmonicBondForce();
        HarmonicAngleForce* angles = new HarmonicAngleForce();
        NonbondedForce* nonbonded = new NonbondedForce();
        nonbonded->setNonbondedMethod(NonbondedForce::PME);
        nonbonded->setCutoffDistance(0.6);
        system.setDefaultPeriodicBoxVectors(Vec3(1.5, 0, 0), Vec3(0, 1.5, 0), Vec3(0, 0, 1.5));
        for (int m = 0; m < 27; ++m) {
            const int o = 4 * m;
            for (double mass : {15.19943, 1.008, 1.008, 0.4})
                system.addParticle(mass);
            nonbonded->addParticle(1.71636 - 1.11466, 0.318395, 0.882110);
            nonbonded->addParticle(0.55733, 0.1, 0.2);
            nonbonded->addParticle(0.55733, 0.1, 0.2);
            nonbonded->addParticle(-1.71636, 0.1, 0.2);
            for (int i = 0; i < 4; ++i)
                for (int j = i + 1; j < 4; ++j)
                    nonbonded->addException(o + i, o + j, 0.0, 1.0, 0.0);
            drude->addBond(o, o + 3, 0.0, 418400.0);
            // The same spring: k = q^2 / (4 pi eps0 alpha).
            drudeSprings->addParticle(o + 3, o, -1, -1, -1, -1.71636, ONE_4PI_EPS0 * 1.71636 * 1.71636 / 418400.0, 1.0,
                                      1.0);
            if (rigid) {
                system.addConstraint(o, o + 1, oh);
                system.addConstraint(o, o + 2, oh);
                system.addConstraint(o + 1, o + 2, 0.15139);
            } else {
                bonds->addBond(o, o + 1, oh, 3e5);
                bonds->addBond(o, o + 2, oh, 3e5);
                angles->addAngle(o + 1, o, o + 2, angle, 400.0);
            }
            const Vec3 origin(0.5 * (m % 3) + 0.1, 0.5 * ((m / 3) % 3) + 0.1, 0.5 * (m / 9) + 0.1);
            const double turn = 0.7 * m;
            positions.push_back(origin);
            positions.push_back(origin + Vec3(oh * std::cos(turn), oh * std::sin(turn), tilt));
            positions.push_back(origin + Vec3(oh * std::cos(turn + angle), oh * std::sin(turn + angle), -tilt));
            positions.push_back(origin + Vec3(0.002, -0.001, 0.0015));
            for (int i = 0; i < 4; ++i)
                velocities.push_back(
                    Vec3(0.5 * std::cos(1.3 * (o + i)), 0.5 * std::sin(0.7 * (o + i)), 0.5 * std::cos(2.1 * (o + i))));
        }
        if (drudeForce) {
            system.addForce(drudeSprings);
            delete drude;
        } else {
            system.addForce(drude);
            delete drudeSprings;
        }
        if (rigid) {
            delete bonds;
            delete angles;
        } else {
            system.addForce(bonds);
            system.addForce(angles);
        }
        system.addForce(nonbonded);
    }
};

/**
 * Flexible TIP3P water with PME in a cubic box, molecules on a grid with turned orientations, the bonds and angles in
 * StiffGroup (the flexible_water scene's force field), thermal-sized velocities from a fixed generator.
 */
struct FlexibleWater {
    System system;
    vector<Vec3> positions, velocities;
    /** With pme false the molecules interact without cutoff (and without periodic box). */
    explicit FlexibleWater(int perSide, bool pme = true, double spacing = 0.62) {
        const double box = perSide * spacing;
        system.setDefaultPeriodicBoxVectors(Vec3(box, 0, 0), Vec3(0, box, 0), Vec3(0, 0, box));
        HarmonicBondForce* bonds = new HarmonicBondForce();
        HarmonicAngleForce* angles = new HarmonicAngleForce();
        NonbondedForce* nonbonded = new NonbondedForce();
        nonbonded->setNonbondedMethod(pme ? NonbondedForce::PME : NonbondedForce::NoCutoff);
        nonbonded->setCutoffDistance(0.9);
        nonbonded->setEwaldErrorTolerance(1e-6);
        bonds->setForceGroup(StiffGroup);
        angles->setForceGroup(StiffGroup);
        nonbonded->setForceGroup(SoftGroup);
        std::mt19937 generator(5);
        std::normal_distribution<double> normal;
        const double length = 0.09572, angle = 1.82421813;
        for (int n = 0; n < perSide * perSide * perSide; ++n) {
            const int o = system.addParticle(15.99943), h1 = system.addParticle(1.007947),
                      h2 = system.addParticle(1.007947);
            nonbonded->addParticle(-0.834, 0.315061, 0.636386);
            nonbonded->addParticle(0.417, 1, 0);
            nonbonded->addParticle(0.417, 1, 0);
            for (const auto& pair : {std::make_pair(o, h1), std::make_pair(o, h2), std::make_pair(h1, h2)})
                nonbonded->addException(pair.first, pair.second, 0, 1, 0);
            bonds->addBond(o, h1, length, 462750.4);
            bonds->addBond(o, h2, length, 462750.4);
            angles->addAngle(h1, o, h2, angle, 836.8);
            const Vec3 centre((n % perSide + 0.5) * spacing, (n / perSide % perSide + 0.5) * spacing,
                              (n / (perSide * perSide) + 0.5) * spacing);
            const double turn = 0.7 * n;
            const Vec3 u(std::cos(turn), std::sin(turn), 0), w(-std::sin(turn) * 0.6, std::cos(turn) * 0.6, 0.8);
            positions.push_back(centre);
            positions.push_back(centre + u * (length * std::cos(angle / 2)) + w * (length * std::sin(angle / 2)));
            positions.push_back(centre + u * (length * std::cos(angle / 2)) - w * (length * std::sin(angle / 2)));
            for (int i : {o, h1, h2}) {
                const double speed = std::sqrt(BOLTZ * 300.0 / system.getParticleMass(i));
                velocities.push_back(Vec3(normal(generator), normal(generator), normal(generator)) * speed);
            }
        }
        system.addForce(bonds);
        system.addForce(angles);
        system.addForce(nonbonded);
    }
};

/** The largest difference of two lists of vectors in any coordinate. */
double largestDifference(const vector<Vec3>& a, const vector<Vec3>& b) {
    double largest = 0.0;
    for (size_t i = 0; i < a.size(); ++i)
        for (int d = 0; d < 3; ++d)
            largest = std::max(largest, std::abs(a[i][d] - b[i][d]));
    return largest;
}

/** Initial positions and velocities of a test system. */
struct Start {
    vector<Vec3> positions, velocities;
};

/**
 * Six Drude pairs (core 15.2, Drude 0.4, k = 418400) near the origin, each particle on an anisotropic soft tether and
 * the Drude particles pulled by a field, and one free particle on a soft isotropic tether: near the origin, where
 * single precision rounds positions least, so that the platforms' trajectories can be compared closely.
 */
struct DrudePairs {
    System system;
    Start start;
    DrudePairs() {
        HarmonicBondForce* springs = new HarmonicBondForce();
        springs->setForceGroup(StiffGroup);
        CustomExternalForce* soft =
            new CustomExternalForce("0.5*a*((x-x0)^2+2*(y-y0)^2+3*(z-z0)^2) - e*(x+0.5*y)*drude");
        soft->addGlobalParameter("a", 2e3);
        soft->addGlobalParameter("e", 300.0);
        for (const char* name : {"x0", "y0", "z0", "drude"})
            soft->addPerParticleParameter(name);
        for (int m = 0; m < 6; ++m) {
            const int core = 2 * m;
            system.addParticle(15.2);
            system.addParticle(0.4);
            springs->addBond(core, core + 1, 0.0, 418400.0);
            const Vec3 centre(0.05 * (m % 3) - 0.05, 0.04 * (m / 3), 0.01 * m);
            start.positions.push_back(centre);
            start.positions.push_back(centre + Vec3(0.002, -0.001, 0.0015));
            for (int i = 0; i < 2; ++i) {
                soft->addParticle(core + i, {centre[0] + 0.01, centre[1] - 0.01, centre[2] + 0.005 * i, (double)i});
                const int k = core + i;
                start.velocities.push_back(
                    Vec3(0.3 * std::cos(1.3 * k), 0.3 * std::sin(0.7 * k), 0.3 * std::cos(2.1 * k)));
            }
        }
        system.addParticle(1.0);
        CustomExternalForce* free = new CustomExternalForce("50*(x^2+y^2+z^2)");
        free->addParticle(12, {});
        start.positions.push_back(Vec3(0.01, 0.02, -0.01));
        start.velocities.push_back(Vec3(0.5, -0.2, 0.1));
        system.addForce(springs);
        system.addForce(soft);
        system.addForce(free);
    }
};

/** One integrator on Reference and on a GPU platform (double precision unless told), stepped side by side. */
template <class IntegratorType> struct SideBySide {
    std::unique_ptr<IntegratorType> reference, gpu;
    std::unique_ptr<Context> referenceContext, gpuContext;
    /** nm/ps: the largest difference of the velocities after the last run(). */
    double velocityDeviation = 0.0;
    SideBySide(const string& platform, const System& system, const std::function<IntegratorType*()>& make,
               const string& precision = "double")
        : reference(make()), gpu(make()) {
        referenceContext = std::make_unique<Context>(system, *reference, Platform::getPlatformByName("Reference"));
        gpuContext = std::make_unique<Context>(system, *gpu, Platform::getPlatformByName(platform),
                                               std::map<string, string>{{"Precision", precision}});
    }
    /** Applies a setting to both integrators, starts both from the same state and returns the largest deviation. */
    double run(const std::function<void(IntegratorType&)>& setting, const Start& start) {
        double largest = 0.0;
        setting(*reference);
        setting(*gpu);
        for (Context* context : {referenceContext.get(), gpuContext.get()}) {
            context->setTime(0.0);
            context->setPositions(start.positions);
            context->setVelocities(start.velocities);
        }
        reference->step(Steps);
        gpu->step(Steps);
        const State a = referenceContext->getState(State::Positions | State::Velocities);
        const State b = gpuContext->getState(State::Positions | State::Velocities);
        largest = largestDifference(a.getPositions(), b.getPositions());
        velocityDeviation = largestDifference(a.getVelocities(), b.getVelocities());
        EXPECT_NEAR(a.getTime(), b.getTime(), 1e-12);
        return largest;
    }
};

/**
 * Runs the settings in order (each adds to the ones before it) from start and expects every run to end within
 * Tolerance of Reference; label names the integrator in the output.
 */
template <class IntegratorType> using Settings = vector<std::pair<string, std::function<void(IntegratorType&)>>>;

template <class IntegratorType>
void expectSettingsFollowReference(SideBySide<IntegratorType>& pair, const char* label,
                                   const Settings<IntegratorType>& settings, const FpuChains& chains) {
    for (const auto& setting : settings) {
        const double deviation = pair.run(setting.second, {chains.positions, chains.velocities});
        std::cout << label << " " << setting.first << ": largest deviation from Reference " << deviation << " nm, "
                  << pair.velocityDeviation << " nm/ps" << std::endl;
        EXPECT_LE(deviation, Tolerance) << setting.first;
    }
}

/** The drude_water scene's SIM: Warped, Middle placement, the Drude modes at 1 K with friction 20/ps. */
StochasticImpulseIntegrator* warpedMiddleColdBath(double step, int seed) {
    using S = StochasticImpulseIntegrator;
    S* s = new S(300.0, 1.0, step, StiffMask);
    s->setSplitting(S::Warped);
    s->setThermostatPlacement(S::Middle);
    s->setStiffModeTemperature(1.0);
    s->setStiffModeFriction(20.0);
    s->setRandomNumberSeed(seed);
    return s;
}

/** A test run once on each GPU platform, skipped where OpenMM has none of that name or this build has no backend. */
class ComputeBackend : public ::testing::TestWithParam<string> {
protected:
    void SetUp() override {
        if (!haveBackend(GetParam()))
            GTEST_SKIP() << "no " << GetParam() << " platform";
    }
};

} // namespace

INSTANTIATE_TEST_SUITE_P(GpuPlatforms, ComputeBackend, ::testing::Values("OpenCL", "CUDA"),
                         [](const ::testing::TestParamInfo<string>& info) { return info.param; });

TEST_P(ComputeBackend, FlavorFollowsReferenceInDoublePrecision) {
    // The nonintrusive FLAVOR all on the device; then the artificial averagings, whose frozen stage runs on the host
    // through the engine's own FrozenDistances and FrozenFlowTask (the kicks, drifts, thermostats and the exact fast
    // flow on the device).  FPU chains: the stiff springs are quadratic, so their nonzero modes freeze.
    using F = FlavorIntegrator;
    FpuChains chains;
    SideBySide<F> flavors(GetParam(), *chains.system, [] {
        F* f = new F(0.02, 0.004, StiffMask);
        f->setTemperature(300.0);
        f->setRandomNumberSeed(31);
        return f;
    });
    // In this order: each setting adds to the last.
    const Settings<F> settings = {
        {"verlet", [](F& f) { f.setScheme(F::Verlet); }},
        {"euler", [](F& f) { f.setScheme(F::SymplecticEuler); }},
        {"euler/langevin", [](F& f) { f.setFriction(5.0); }},
        {"verlet/langevin",
         [](F& f) {
             f.setScheme(F::Verlet);
             f.setFriction(5.0);
         }},
        {"verlet/stiff-friction", [](F& f) { f.setStiffFriction(true); }},
        {"verlet/friction-particles",
         [](F& f) {
             f.setStiffFriction(false);
             f.setFrictionParticles({0, 3, 7});
         }},
        {"artificial", [](F& f) { f.setAveraging(F::Artificial); }},
        {"projected", [](F& f) { f.setAveraging(F::ArtificialProjected); }},
        {"projected/langevin/middle",
         [](F& f) {
             f.setFriction(5.0);
             f.setThermostatPlacement(F::Middle);
         }},
        {"projected/exact-fast-flow",
         [](F& f) {
             f.setThermostatPlacement(F::Edges);
             f.setExactFastFlow(true);
         }},
        {"euler/artificial",
         [](F& f) {
             f.setExactFastFlow(false);
             f.setScheme(F::SymplecticEuler);
             f.setAveraging(F::Artificial);
         }},
    };
    expectSettingsFollowReference(flavors, "FLAVOR", settings, chains);
}

TEST_P(ComputeBackend, StochasticImpulseFollowsReferenceInDoublePrecision) {
    using S = StochasticImpulseIntegrator;
    FpuChains chains;
    SideBySide<S> sims(GetParam(), *chains.system, [] {
        S* s = new S(300.0, 0.0, 0.02, StiffMask);
        s->setRandomNumberSeed(37);
        return s;
    });
    const Settings<S> settings = {
        {"strang", [](S& s) { s.setSplitting(S::Strang); }},
        {"strang/langevin", [](S& s) { s.setFriction(5.0); }},
        {"strang/mode-bath",
         [](S& s) {
             s.setStiffModeTemperature(10.0);
             s.setStiffModeFriction(20.0);
         }},
        {"lie-trotter/langevin", [](S& s) { s.setSplitting(S::LieTrotter); }},
        {"yoshida4",
         [](S& s) {
             s.setFriction(0.0);
             s.setStiffModeFriction(0.0);
             s.setSplitting(S::Yoshida4);
         }},
        // A cold stiff-mode bath, as for Drude particles.
        {"filtered",
         [](S& s) {
             s.setSplitting(S::Filtered);
             s.setFriction(5.0);
             s.setStiffModeTemperature(1.0);
             s.setStiffModeFriction(20.0);
         }},
        {"filtered/middle", [](S& s) { s.setThermostatPlacement(S::Middle); }},
        {"warped/middle", [](S& s) { s.setSplitting(S::Warped); }},
        {"warped", [](S& s) { s.setThermostatPlacement(S::Throughout); }},
        // Slowed below the warped frequency, with scaled kicks (the limit acts where the warped turn exceeds 0.5).
        {"warped, phase limited", [](S& s) { s.setMaxWarpedPhase(0.5); }},
    };
    expectSettingsFollowReference(sims, "SIM", settings, chains);
}

TEST_P(ComputeBackend, FilteredCheckpointsCarryTheStepHistory) {
    // The velocity processing of a Filtered step undoes that of the step before: a checkpoint holds the force
    // differences it needs, so a loaded checkpoint continues as the run that wrote it.
    using S = StochasticImpulseIntegrator;
    FpuChains chains;
    for (S::Splitting splitting : {S::Filtered, S::Warped}) {
        S sim(300.0, 5.0, 0.02, StiffMask);
        sim.setSplitting(splitting);
        sim.setThermostatPlacement(S::Middle);
        sim.setStiffModeTemperature(1.0);
        sim.setStiffModeFriction(20.0);
        sim.setRandomNumberSeed(41);
        Context context(*chains.system, sim, Platform::getPlatformByName(GetParam()),
                        std::map<string, string>{{"Precision", "double"}});
        context.setPositions(chains.positions);
        context.setVelocities(chains.velocities);
        sim.step(5);
        std::stringstream checkpoint;
        context.createCheckpoint(checkpoint);
        sim.step(10);
        const vector<Vec3> q = context.getState(State::Positions).getPositions();
        context.loadCheckpoint(checkpoint);
        sim.step(10);
        EXPECT_EQ(0.0, largestDifference(context.getState(State::Positions).getPositions(), q))
            << (splitting == S::Filtered ? "Filtered" : "Warped");
    }
}

TEST_P(ComputeBackend, SettingTheStateForgetsTheFilteredStepHistory) {
    // After setPositions and setVelocities the next Filtered step is the one a new Context takes from that state (the
    // history kept, the FPU chains end 7e-7 nm away).  Without friction, so the random streams play no part.
    using S = StochasticImpulseIntegrator;
    FpuChains chains;
    const std::map<string, string> properties{{"Precision", "double"}};
    S used(0.0, 0.0, 0.02, StiffMask), fresh(0.0, 0.0, 0.02, StiffMask);
    for (S* sim : {&used, &fresh})
        sim->setSplitting(S::Filtered);
    Context usedContext(*chains.system, used, Platform::getPlatformByName(GetParam()), properties);
    Context freshContext(*chains.system, fresh, Platform::getPlatformByName(GetParam()), properties);
    usedContext.setPositions(chains.positions);
    usedContext.setVelocities(chains.velocities);
    used.step(10);
    for (Context* context : {&usedContext, &freshContext}) {
        context->setPositions(chains.positions);
        context->setVelocities(chains.velocities);
    }
    used.step(10);
    fresh.step(10);
    EXPECT_EQ(0.0, largestDifference(usedContext.getState(State::Positions).getPositions(),
                                     freshContext.getState(State::Positions).getPositions()));
}

TEST_P(ComputeBackend, DrudeWatersWithPmeFollowReferenceInDoublePrecision) {
    // The Warped step with Middle zero modes and a cold Drude bath, as for SWM4-NDP water: the force responses of
    // Drude pairs and of free hydrogens.  PME forces differ by rounding between the platforms.
    using S = StochasticImpulseIntegrator;
    DrudeWaters waters;
    SideBySide<S> sims(GetParam(), waters.system, [] { return warpedMiddleColdBath(0.001, 43); });
    const double largest = sims.run([](S&) {}, {waters.positions, waters.velocities});
    std::cout << "SIM Drude waters (PME, warped/middle): largest deviation from Reference " << largest << " nm"
              << std::endl;
    EXPECT_LE(largest, 1e-5);
}

TEST_P(ComputeBackend, RigidDrudeWatersRunInMixedPrecisionOnTheStiffModesOfReference) {
    // In mixed (and single) precision OpenCL rounds positions to single precision, about 1e-7 nm in this 1.5-nm box:
    // probed through the Context, the Drude springs measured 1e-4 relative asymmetric and the SIM refused them as not
    // quadratic.  Probed on the Reference copy of the stiff forces, the modes are Reference's, and the step follows
    // Reference as far as single-precision soft forces allow.
    using S = StochasticImpulseIntegrator;
    DrudeWaters waters(true);
    SideBySide<S> sims(
        GetParam(), waters.system, [] { return warpedMiddleColdBath(0.002, 59); }, "mixed");
    sims.referenceContext->setPositions(waters.positions);
    sims.gpuContext->setPositions(waters.positions);
    const vector<double> expected = sims.reference->getStiffModeFrequencies();
    const vector<double> measured = sims.gpu->getStiffModeFrequencies();
    ASSERT_EQ(expected.size(), measured.size());
    for (size_t m = 0; m < expected.size(); ++m)
        EXPECT_NEAR(expected[m], measured[m], 1e-10 * expected[m]) << m;
    const double largest = sims.run([](S&) {}, {waters.positions, waters.velocities});
    std::cout << "SIM rigid Drude waters (PME, warped/middle), mixed precision: largest deviation from Reference "
              << largest << " nm, " << sims.velocityDeviation << " nm/ps" << std::endl;
    // Measured 2.4e-6 nm after 45 steps of 2 fs.
    EXPECT_LE(largest, 1e-5);
}

TEST_P(ComputeBackend, StochasticImpulseWithConstraintsFollowsReference) {
    // A constraint between the stiff pairs of an FPU chain: the constraint solve runs on the host through the engine's
    // ConstraintProjector, and each pair's flow carries the constraint impulses on its constrained particle to the
    // other.
    using S = StochasticImpulseIntegrator;
    FpuChains chains;
    std::unique_ptr<System> system(fpuSystem(3, 50.0, 2));
    const Vec3 link = chains.positions[1] - chains.positions[2];
    system->addConstraint(1, 2, std::sqrt(link.dot(link)));
    const Settings<S> settings = {
        {"strang", [](S& s) { s.setSplitting(S::Strang); }},
        {"lie-trotter/langevin",
         [](S& s) {
             s.setSplitting(S::LieTrotter);
             s.setFriction(5.0);
         }},
        {"yoshida4",
         [](S& s) {
             s.setFriction(0.0);
             s.setSplitting(S::Yoshida4);
         }},
        // A cold stiff-mode bath, as for Drude particles.
        {"filtered",
         [](S& s) {
             s.setSplitting(S::Filtered);
             s.setFriction(5.0);
             s.setStiffModeTemperature(1.0);
             s.setStiffModeFriction(20.0);
         }},
        {"warped/middle",
         [](S& s) {
             s.setSplitting(S::Warped);
             s.setThermostatPlacement(S::Middle);
         }},
        {"warped/middle, phase limited", [](S& s) { s.setMaxWarpedPhase(0.5); }},
    };
    SideBySide<S> sims(GetParam(), *system, [] {
        S* s = new S(300.0, 0.0, 0.02, StiffMask);
        s->setRandomNumberSeed(53);
        return s;
    });
    expectSettingsFollowReference(sims, "SIM with constraints,", settings, chains);
    // A checkpoint holds the step history (the Middle placement's constraint processing among it).
    std::stringstream checkpoint;
    sims.gpuContext->createCheckpoint(checkpoint);
    sims.gpu->step(10);
    const vector<Vec3> q = sims.gpuContext->getState(State::Positions).getPositions();
    sims.gpuContext->loadCheckpoint(checkpoint);
    sims.gpu->step(10);
    EXPECT_EQ(0.0, largestDifference(sims.gpuContext->getState(State::Positions).getPositions(), q));
}

TEST_P(ComputeBackend, RigidDrudeWatersWithPmeFollowReference) {
    // Rigid SWM4-NDP-like waters, the drude_water scene's model: the Warped step with Middle zero modes and a cold
    // Drude bath, each oxygen core held by SETTLE.  What is left is the difference of the
    // platforms' PME: 1.6e-8 nm at its error tolerance 1e-6 (2.4e-5 nm at 1e-5; 1.5e-6 nm with a 0.74 nm cutoff).
    // About 15 s on PoCL, most of it PME's 96^3 grid on both platforms.
    using S = StochasticImpulseIntegrator;
    DrudeWaters waters(true);
    for (int f = 0; f < waters.system.getNumForces(); ++f)
        if (auto* nonbonded = dynamic_cast<NonbondedForce*>(&waters.system.getForce(f)))
            nonbonded->setEwaldErrorTolerance(1e-6);
    SideBySide<S> sims(GetParam(), waters.system, [] { return warpedMiddleColdBath(0.002, 59); });
    const double largest = sims.run([](S&) {}, {waters.positions, waters.velocities});
    std::cout << "SIM rigid Drude waters (PME, warped/middle): largest deviation from Reference " << largest << " nm, "
              << sims.velocityDeviation << " nm/ps" << std::endl;
    EXPECT_LE(largest, 1e-5);
}

TEST_P(ComputeBackend, RigidDrudeWatersSolveTheirConstraintsOnTheDeviceAsReferenceDoes) {
    // SETTLE holds each oxygen core: the device solves the constraints around the stiff flows with the cores' masses
    // of each solve (DeviceCarriedConstraints) where Reference runs the host's ConstraintProjector.  Every splitting,
    // the Filtered one with its velocity processing, which a checkpoint carries.  No PME, so that what is left is
    // the solves' rounding.
    using S = StochasticImpulseIntegrator;
    DrudeWaters waters(true);
    for (int f = 0; f < waters.system.getNumForces(); ++f)
        if (dynamic_cast<NonbondedForce*>(&waters.system.getForce(f)))
            waters.system.removeForce(f--);
    // A field on the Drude particles and the hydrogens instead, the same on both platforms to rounding.
    CustomExternalForce* field = new CustomExternalForce("-q*(3*x+2*y-z)");
    field->addPerParticleParameter("q");
    for (int m = 0; m < 27; ++m) {
        field->addParticle(4 * m + 1, {0.55733});
        field->addParticle(4 * m + 2, {0.55733});
        field->addParticle(4 * m + 3, {-1.71636});
    }
    waters.system.addForce(field);
    const Settings<S> settings = {
        {"warped/middle", [](S&) {}},
        {"filtered/middle", [](S& s) { s.setSplitting(S::Filtered); }},
        {"filtered/throughout", [](S& s) { s.setThermostatPlacement(S::Throughout); }},
        {"strang", [](S& s) { s.setSplitting(S::Strang); }},
        {"lie-trotter", [](S& s) { s.setSplitting(S::LieTrotter); }},
    };
    SideBySide<S> sims(GetParam(), waters.system, [] { return warpedMiddleColdBath(0.002, 67); });
    for (const auto& setting : settings) {
        const double deviation = sims.run(setting.second, {waters.positions, waters.velocities});
        std::cout << "SIM rigid Drude waters, " << setting.first << ": largest deviation from Reference " << deviation
                  << " nm, " << sims.velocityDeviation << " nm/ps" << std::endl;
        // Measured 1.0-1.1e-9 nm after 45 steps of 2 fs (OpenMM's device SETTLE rounds otherwise than Reference's;
        // the host's solves on OpenCL: 1.4-1.6e-10); the Filtered steps without the carriers' velocity motions 8e-5.
        EXPECT_LE(deviation, 1e-8) << setting.first;
    }
    // Filtered with Middle placement processes each step's velocities; a loaded checkpoint continues the same run.
    S& sim = *sims.gpu;
    sim.setSplitting(S::Filtered);
    sim.setThermostatPlacement(S::Middle);
    sims.gpuContext->setPositions(waters.positions);
    sims.gpuContext->setVelocities(waters.velocities);
    sim.step(5);
    std::stringstream checkpoint;
    sims.gpuContext->createCheckpoint(checkpoint);
    sim.step(5);
    const vector<Vec3> q = sims.gpuContext->getState(State::Positions).getPositions();
    sims.gpuContext->loadCheckpoint(checkpoint);
    sim.step(5);
    EXPECT_EQ(0.0, largestDifference(sims.gpuContext->getState(State::Positions).getPositions(), q));
}

TEST_P(ComputeBackend, FilteredAndWarpedFollowReferenceInSingleAndMixedPrecision) {
    using S = StochasticImpulseIntegrator;
    DrudePairs pairs;
    const Settings<S> settings = {
        {"filtered", [](S& s) { s.setSplitting(S::Filtered); }},
        {"warped/middle",
         [](S& s) {
             s.setSplitting(S::Warped);
             s.setThermostatPlacement(S::Middle);
         }},
    };
    for (const char* precision : {"mixed", "single"}) {
        SideBySide<S> sims(
            GetParam(), pairs.system,
            [] {
                S* s = new S(300.0, 5.0, 0.002, StiffMask);
                s->setStiffModeTemperature(1.0);
                s->setStiffModeFriction(20.0);
                s->setRandomNumberSeed(47);
                return s;
            },
            precision);
        for (const auto& setting : settings) {
            const double deviation = sims.run(setting.second, pairs.start);
            std::cout << "SIM Drude pairs, " << setting.first << ", " << precision
                      << " precision: largest deviation from Reference " << deviation << " nm" << std::endl;
            // Single-precision rounding of positions near 0.1 nm and of the forces.
            EXPECT_LE(deviation, 1e-6) << setting.first << ", " << precision;
        }
    }
}

TEST_P(ComputeBackend, ConstrainedDrudePairsFollowReferenceInSingleAndMixedPrecision) {
    // Two Drude cores held at their distance, each with its Drude particle: the host's copies of the state in the
    // precisions that keep positions in single (with a correction in mixed).
    using S = StochasticImpulseIntegrator;
    DrudePairs pairs;
    const Vec3 link = pairs.start.positions[0] - pairs.start.positions[2];
    pairs.system.addConstraint(0, 2, std::sqrt(link.dot(link)));
    for (const char* precision : {"mixed", "single"}) {
        SideBySide<S> sims(
            GetParam(), pairs.system,
            [] {
                S* s = new S(300.0, 5.0, 0.002, StiffMask);
                s->setSplitting(S::Warped);
                s->setThermostatPlacement(S::Middle);
                s->setStiffModeTemperature(1.0);
                s->setStiffModeFriction(20.0);
                s->setRandomNumberSeed(61);
                return s;
            },
            precision);
        const double deviation = sims.run([](S&) {}, pairs.start);
        std::cout << "SIM constrained Drude pairs, warped/middle, " << precision
                  << " precision: largest deviation from Reference " << deviation << " nm" << std::endl;
        EXPECT_LE(deviation, 1e-6) << precision;
    }
}

TEST_P(ComputeBackend, MetropolisAdjustedStepsFollowReference) {
    // The proposals' states stay on the device, their energies come to the host for the test with the same uniform
    // numbers as Reference's: in double precision every accept decision and so the trajectory is Reference's, at a
    // temperature and step where some proposals are rejected.
    FpuChains chains;
    SideBySide<FlavorIntegrator> flavors(GetParam(), *chains.system, [] {
        FlavorIntegrator* f = new FlavorIntegrator(0.03, 0.006, StiffMask);
        f->setScheme(FlavorIntegrator::Verlet);
        f->setTemperature(300.0);
        f->setFriction(5.0);
        f->setMetropolis(true);
        f->setRandomNumberSeed(29);
        return f;
    });
    const double flavorDeviation = flavors.run([](FlavorIntegrator&) {}, {chains.positions, chains.velocities});
    SideBySide<StochasticImpulseIntegrator> sims(GetParam(), *chains.system, [] {
        StochasticImpulseIntegrator* s = new StochasticImpulseIntegrator(300.0, 5.0, 0.05, StiffMask);
        s->setSplitting(StochasticImpulseIntegrator::Strang);
        s->setMetropolis(true);
        s->setRandomNumberSeed(31);
        return s;
    });
    const double simDeviation = sims.run([](StochasticImpulseIntegrator&) {}, {chains.positions, chains.velocities});
    const double rates[2][2] = {{flavors.reference->getAcceptanceRate(), flavors.gpu->getAcceptanceRate()},
                                {sims.reference->getAcceptanceRate(), sims.gpu->getAcceptanceRate()}};
    std::cout << "Metropolis FLAVOR: largest deviation from Reference " << flavorDeviation << " nm, acceptance "
              << rates[0][1] << " (Reference " << rates[0][0] << "); SIM " << simDeviation << " nm, acceptance "
              << rates[1][1] << " (Reference " << rates[1][0] << ")" << std::endl;
    for (int i = 0; i < 2; ++i) {
        EXPECT_EQ(rates[i][0], rates[i][1]);
        EXPECT_LT(rates[i][1], 1.0) << "no proposal rejected: the test would not see a rejection";
    }
    EXPECT_LE(flavorDeviation, Tolerance);
    EXPECT_LE(simDeviation, Tolerance);
}

TEST_P(ComputeBackend, ArtificialFlavorOnFlexibleWaterFollowsReference) {
    // 27 flexible TIP3P waters with PME, their O-H bonds and H-O-H angles frozen between microsteps (frozen distances,
    // one cluster per molecule), as in the flexible_water scene: the reordering of molecules on the device leaves the
    // host's frozen stage the same clusters.  The platforms' PME differ by about their error tolerance: at OpenMM's
    // default 5e-4 the nonintrusive FLAVOR, all on the device, already ends 5e-4 nm apart; at 1e-6 (here) every
    // averaging ends within 1e-7 nm (measured 3e-8 to 9e-8).
    using F = FlavorIntegrator;
    FlexibleWater water(3);
    SideBySide<F> flavors(GetParam(), water.system, [] {
        F* f = new F(0.004, 0.0005, StiffMask);
        f->setAveraging(F::ArtificialProjected);
        f->setTemperature(300.0);
        f->setFriction(1.0);
        f->setRandomNumberSeed(41);
        return f;
    });
    const std::map<string, std::function<void(F&)>> settings = {
        {"projected/middle", [](F& f) { f.setThermostatPlacement(F::Middle); }},
        {"projected/edges", [](F& f) { f.setThermostatPlacement(F::Edges); }},
        {"artificial/edges", [](F& f) { f.setAveraging(F::Artificial); }},
    };
    for (const char* name : {"projected/middle", "projected/edges", "artificial/edges"}) {
        const double deviation = flavors.run(settings.at(name), {water.positions, water.velocities});
        std::cout << "FLAVOR " << name << " on flexible water: largest deviation from Reference " << deviation << " nm"
                  << std::endl;
        EXPECT_LE(deviation, 1e-6) << name;
        // Each molecule's two bonds and its H-H distance.
        EXPECT_NE(flavors.gpu->describeContext().find("frozen: 81 distances"), string::npos)
            << flavors.gpu->describeContext();
    }
}

/** What the preloaded OpenCL test layer counted while an integrator took steps steps after warmUp steps. */
OpenCLCallCounts countSteps(Integrator& integrator, const System& system, const Start& start, int warmUp, int steps) {
    const auto counts = reinterpret_cast<OpenCLCallCountsFunction>(dlsym(RTLD_DEFAULT, OpenCLCallCountsSymbol));
    Context context(const_cast<System&>(system), integrator, Platform::getPlatformByName("OpenCL"),
                    {{"Precision", "mixed"}});
    context.setPositions(start.positions);
    context.setVelocities(start.velocities);
    integrator.step(warmUp);
    OpenCLCallCounts before, after;
    counts(&before);
    integrator.step(steps);
    counts(&after);
    return {after.launches - before.launches,
            after.reads - before.reads,
            after.blockingReads - before.blockingReads,
            after.writes - before.writes,
            after.blockingWrites - before.blockingWrites,
            after.waits - before.waits};
}

TEST_P(ComputeBackend, TheArtificialFlavorStepsOnFlexibleWaterWithoutBlockingTransfers) {
    // Counted on OpenCL by the preloaded test layer (OpenCLCallCounts.cpp): per step after warm-up, the FLAVOR of the
    // flexible-water recipe (ArtificialProjected, Middle, delta = 6 fs, tau = 0.5 fs; its frozen stage on the device)
    // beside OpenMM's LangevinMiddle at 2 fs on the same 125 molecules with PME, mixed precision.
    if (GetParam() != "OpenCL")
        GTEST_SKIP() << "counted through the OpenCL library";
    if (dlsym(RTLD_DEFAULT, OpenCLCallCountsSymbol) == nullptr)
        GTEST_SKIP() << "needs the OpenCL test layer preloaded (ctest and make test preload it)";
    using F = FlavorIntegrator;
    FlexibleWater water(5);
    const Start start{water.positions, water.velocities};
    const int steps = 20;
    F flavor(0.006, 0.0005, StiffMask);
    flavor.setAveraging(F::ArtificialProjected);
    flavor.setThermostatPlacement(F::Middle);
    flavor.setTemperature(300.0);
    flavor.setFriction(1.0);
    const OpenCLCallCounts ours = countSteps(flavor, water.system, start, 3, steps);
    LangevinMiddleIntegrator langevin(300.0, 1.0, 0.002);
    const OpenCLCallCounts peer = countSteps(langevin, water.system, start, 3, steps);
    for (const auto& row : {std::make_pair("FLAVOR delta 6 fs", ours), std::make_pair("LangevinMiddle 2 fs", peer)})
        std::cout << row.first << " per step: " << row.second.launches / (double)steps << " launches, "
                  << row.second.reads / (double)steps << " reads (" << row.second.blockingReads / (double)steps
                  << " blocking), " << row.second.writes / (double)steps << " writes ("
                  << row.second.blockingWrites / (double)steps << " blocking), " << row.second.waits / (double)steps
                  << " waits" << std::endl;
    EXPECT_EQ(ours.blockingReads, 0);
    EXPECT_EQ(ours.blockingWrites, 0);
    EXPECT_LE(ours.launches, 1.5 * peer.launches);
    // Its one read per step: the frozen stage's 4-byte failure flag, without waiting.
    EXPECT_LE(ours.reads, peer.reads + steps);
}

TEST_P(ComputeBackend, TheSimStepsOnRigidDrudeWaterWithoutBlockingTransfers) {
    // Counted as the FLAVOR's step above: the SIM of the Drude-water recipe (Warped, Middle, 2.5 fs; SETTLE on every
    // core, solved on the device) beside OpenMM's DrudeLangevin at 1 fs on the same 27 rigid SWM4-NDP-like waters.
    if (GetParam() != "OpenCL")
        GTEST_SKIP() << "counted through the OpenCL library";
    if (dlsym(RTLD_DEFAULT, OpenCLCallCountsSymbol) == nullptr)
        GTEST_SKIP() << "needs the OpenCL test layer preloaded (ctest and make test preload it)";
    DrudeWaters waters(true, true);
    const Start start{waters.positions, waters.velocities};
    const int steps = 20;
    // Without and with the 0.02-nm hard wall on both (the wall's failure flag is read without waiting).
    for (double wall : {0.0, 0.02}) {
        std::unique_ptr<StochasticImpulseIntegrator> sim(warpedMiddleColdBath(0.0025, 71));
        sim->setMaxDrudeDistance(wall);
        const OpenCLCallCounts ours = countSteps(*sim, waters.system, start, 3, steps);
        DrudeLangevinIntegrator drudeLangevin(300.0, 1.0, 1.0, 20.0, 0.001);
        drudeLangevin.setMaxDrudeDistance(wall);
        const OpenCLCallCounts peer = countSteps(drudeLangevin, waters.system, start, 3, steps);
        for (const auto& row : {std::make_pair("SIM 2.5 fs", ours), std::make_pair("DrudeLangevin 1 fs", peer)})
            std::cout << row.first << ", wall " << wall << " nm, per step: " << row.second.launches / (double)steps
                      << " launches, " << row.second.reads / (double)steps << " reads ("
                      << row.second.blockingReads / (double)steps << " blocking), " << row.second.writes / (double)steps
                      << " writes (" << row.second.blockingWrites / (double)steps << " blocking)" << std::endl;
        EXPECT_EQ(ours.blockingReads, 0) << wall;
        EXPECT_EQ(ours.blockingWrites, 0) << wall;
        EXPECT_LE(ours.launches, 1.25 * peer.launches) << wall;
        EXPECT_LE(ours.reads, peer.reads + (wall > 0 ? steps : 0)) << wall;
    }
}

TEST_P(ComputeBackend, FlavorsFollowReferenceInSingleAndMixedPrecision) {
    // 45 mesosteps of flexible water (8 molecules, no cutoff) in OpenCL's single and mixed precision against Reference:
    // the nonintrusive FLAVOR and the artificial one with its frozen stage, both all on the device (the frozen stage's
    // clusters in coordinates relative to their first particle, so that single precision keeps its digits).
    using F = FlavorIntegrator;
    FlexibleWater water(2, false);
    for (const char* precision : {"mixed", "single"}) {
        SideBySide<F> flavors(
            GetParam(), water.system,
            [] {
                F* f = new F(0.004, 0.0005, StiffMask);
                f->setTemperature(300.0);
                f->setFriction(1.0);
                f->setThermostatPlacement(F::Middle);
                f->setRandomNumberSeed(43);
                return f;
            },
            precision);
        for (auto averaging : {F::Nonintrusive, F::ArtificialProjected}) {
            const double deviation = flavors.run(
                [averaging](F& f) {
                    f.setAveraging(averaging);
                    f.setThermostatPlacement(averaging == F::Nonintrusive ? F::Edges : F::Middle);
                },
                {water.positions, water.velocities});
            std::cout << "FLAVOR " << (averaging == F::Nonintrusive ? "nonintrusive" : "projected/middle") << ", "
                      << precision << " precision, flexible water: largest deviation from Reference " << deviation
                      << " nm, velocities " << flavors.velocityDeviation << " nm/ps" << std::endl;
            // Single-precision forces, about 1e-6 relative (measured: 4e-7 to 1.6e-6 nm after 45 steps).
            EXPECT_LE(deviation, 1e-5) << precision;
        }
    }
}

TEST_P(ComputeBackend, TheHardWallFollowsReference) {
    // The SIM's hard wall (setMaxDrudeDistance) runs on the device (DeviceHardWall) over the pairs the engine's
    // HardWall finds, which Reference runs.  Six Drude pairs with a wall of 0.0015 nm, inside which the field holds
    // them only part of the time: the wall moves the trajectory (checked against the same run without it), and OpenCL
    // follows Reference.
    using S = StochasticImpulseIntegrator;
    DrudePairs pairs;
    SideBySide<S> sims(GetParam(), pairs.system, [] { return warpedMiddleColdBath(0.002, 61); });
    sims.run([](S& s) { s.setMaxDrudeDistance(0.0); }, pairs.start);
    const vector<Vec3> withoutWall = sims.referenceContext->getState(State::Positions).getPositions();
    const double deviation = sims.run([](S& s) { s.setMaxDrudeDistance(0.0015); }, pairs.start);
    const vector<Vec3> withWall = sims.referenceContext->getState(State::Positions).getPositions();
    std::cout << "SIM Drude pairs with a 0.0015-nm wall: largest deviation from Reference " << deviation
              << " nm; the wall moved the trajectory by " << largestDifference(withWall, withoutWall) << " nm"
              << std::endl;
    EXPECT_GT(largestDifference(withWall, withoutWall), 1e-5);
    EXPECT_LE(deviation, Tolerance);
}

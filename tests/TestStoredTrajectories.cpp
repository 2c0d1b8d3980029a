// Every scheme and setting of both integrators, 25 steps on small systems, compared bit for bit with trajectories
// stored in tests/data/stored_trajectories.txt.  The stored values pin the step engine's arithmetic: a change that
// reorders the engine's work must leave every trajectory exactly as it was.  Writing them again (after a deliberate
// change of a scheme's arithmetic) is
//
//     FLAVORS_WRITE_TRAJECTORIES=tests/data/stored_trajectories.txt build/tests/TestFlavorsPlatforms
//         --gtest_filter='*StoredTrajectories*'
//
// run from the source directory; the file then holds the trajectories of both platforms.

#include "DrudeWater.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/VirtualSite.h"
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::string;
using std::vector;

class StoredTrajectories : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(StoredTrajectories);

namespace {

constexpr int Steps = 25;

struct TestSystem {
    std::shared_ptr<System> system;
    vector<Vec3> positions, velocities;
};

/** Two FPU chains (m = 3, omega = 50): a quadratic stiff group, quartic soft forces; velocities in all directions. */
TestSystem fpuChains() {
    TestSystem t;
    t.system.reset(fpuSystem(3, 50.0, 2));
    t.positions = fpuPositions({1, 0.2, -0.4}, {0.02, -0.01, 0.01}, 2);
    for (size_t i = 0; i < t.positions.size(); ++i) {
        t.positions[i][1] = 0.01 * std::sin(1.3 * i);
        t.velocities.push_back(Vec3(0.3 * std::sin(0.7 * i), 0.1 * std::cos(0.9 * i), 0.05 * std::sin(1.1 * i)));
    }
    return t;
}

/**
 * Four flexible bent molecules with stiff bonds and angles (frozen distances), two rigid waters (System
 * constraints), soft tethers on every particle and a virtual site between the hydrogens of the first molecule that a
 * soft field pulls.
 */
TestSystem bentMoleculesAndWater() {
    TestSystem t;
    t.system = std::make_shared<System>();
    const int molecules = 4, waters = 2;
    for (int m = 0; m < molecules + waters; ++m)
        for (double mass : {15.999, 1.008, 1.008})
            t.system->addParticle(mass);
    addStiffBentMolecules(*t.system, 0, molecules);
    CustomExternalForce* tether = new CustomExternalForce("200*((x-x0)^2+(y-y0)^2+(z-z0)^2)");
    for (const char* p : {"x0", "y0", "z0"})
        tether->addPerParticleParameter(p);
    for (int m = 0; m < molecules + waters; ++m) {
        const Vec3 centre(0.5 * (m % 3), 0.5 * (m / 3), 0.1 * m);
        const vector<Vec3> molecule =
            m >= molecules ? vector<Vec3>{centre, centre + Vec3(0.09572, 0, 0), centre + Vec3(-0.0240, 0.0927, 0)}
                           : bentMoleculePositions(centre);
        if (m >= molecules) {
            const int o = 3 * m;
            t.system->addConstraint(o, o + 1, 0.09572);
            t.system->addConstraint(o, o + 2, 0.09572);
            t.system->addConstraint(o + 1, o + 2, 0.15139);
        }
        for (int k = 0; k < 3; ++k) {
            const Vec3 rest = molecule[k] + Vec3(0.003 * k, -0.002 * m, 0.001);
            tether->addParticle(3 * m + k, {rest[0], rest[1], rest[2]});
            t.positions.push_back(molecule[k]);
            t.velocities.push_back(Vec3(0.4 * std::sin(0.7 * (3 * m + k)), 0.3 * std::cos(1.3 * (3 * m + k)), 0.2));
        }
    }
    tether->setForceGroup(SoftGroup);
    t.system->addForce(tether);
    const int site = t.system->addParticle(0.0);
    t.system->setVirtualSite(site, new TwoParticleAverageSite(1, 2, 0.5, 0.5));
    t.positions.push_back(0.5 * (t.positions[1] + t.positions[2]));
    t.velocities.push_back(Vec3());
    CustomExternalForce* field = new CustomExternalForce("-30*(x+y)");
    field->addParticle(site);
    field->setForceGroup(SoftGroup);
    t.system->addForce(field);
    return t;
}

/** Four rigid SWM4-NDP-like waters whose constrained oxygen is a Drude core, tethered in a field. */
TestSystem drudeWater() {
    auto water = std::make_shared<DrudeWater>(4, false);
    TestSystem t;
    t.system = std::shared_ptr<System>(water, &water->system);
    t.positions = water->positions;
    for (size_t i = 0; i < t.positions.size(); ++i)
        t.velocities.push_back(Vec3(0.2 * std::sin(0.8 * i), -0.3 * std::cos(0.6 * i), 0.1));
    return t;
}

struct Case {
    string name;
    std::function<TestSystem()> makeSystem;
    std::function<Integrator*()> makeIntegrator;
};

FlavorIntegrator* flavor(double delta, double tau, FlavorIntegrator::Scheme scheme,
                         FlavorIntegrator::Averaging averaging, double friction = 0.0) {
    FlavorIntegrator* integrator = new FlavorIntegrator(delta, tau, StiffMask);
    integrator->setScheme(scheme);
    integrator->setAveraging(averaging);
    integrator->setFriction(friction);
    integrator->setTemperature(300.0);
    integrator->setRandomNumberSeed(17);
    return integrator;
}

StochasticImpulseIntegrator* impulse(double stepSize, StochasticImpulseIntegrator::Splitting splitting,
                                     double friction) {
    StochasticImpulseIntegrator* integrator = new StochasticImpulseIntegrator(300.0, friction, stepSize, StiffMask);
    integrator->setSplitting(splitting);
    integrator->setRandomNumberSeed(23);
    return integrator;
}

vector<Case> cases() {
    using F = FlavorIntegrator;
    using S = StochasticImpulseIntegrator;
    const double d = 0.02, t = 0.004;
    vector<Case> c;
    // Nonintrusive FLAVORs on the FPU chains.
    c.push_back({"flavor/nonintrusive/verlet", fpuChains, [=] { return flavor(d, t, F::Verlet, F::Nonintrusive); }});
    c.push_back(
        {"flavor/nonintrusive/euler", fpuChains, [=] { return flavor(d, t, F::SymplecticEuler, F::Nonintrusive); }});
    c.push_back({"flavor/nonintrusive/verlet/langevin", fpuChains,
                 [=] { return flavor(d, t, F::Verlet, F::Nonintrusive, 5.0); }});
    c.push_back({"flavor/nonintrusive/euler/langevin", fpuChains,
                 [=] { return flavor(d, t, F::SymplecticEuler, F::Nonintrusive, 5.0); }});
    c.push_back({"flavor/nonintrusive/verlet/stiff-friction", fpuChains, [=] {
                     F* f = flavor(d, t, F::Verlet, F::Nonintrusive, 5.0);
                     f->setStiffFriction(true);
                     return f;
                 }});
    c.push_back({"flavor/nonintrusive/euler/stiff-friction", fpuChains, [=] {
                     F* f = flavor(d, t, F::SymplecticEuler, F::Nonintrusive, 5.0);
                     f->setStiffFriction(true);
                     return f;
                 }});
    c.push_back({"flavor/nonintrusive/verlet/friction-particles", fpuChains, [=] {
                     F* f = flavor(d, t, F::Verlet, F::Nonintrusive, 5.0);
                     f->setFrictionParticles({0, 3, 7});
                     return f;
                 }});
    // Artificial FLAVORs on the quadratic stiff group (zero-mode projection).
    for (F::Averaging averaging : {F::Artificial, F::ArtificialProjected}) {
        const string a = averaging == F::Artificial ? "artificial" : "projected";
        c.push_back({"flavor/" + a + "/verlet", fpuChains, [=] { return flavor(d, t, F::Verlet, averaging); }});
        c.push_back({"flavor/" + a + "/euler/langevin", fpuChains,
                     [=] { return flavor(d, t, F::SymplecticEuler, averaging, 5.0); }});
        c.push_back(
            {"flavor/" + a + "/verlet/langevin", fpuChains, [=] { return flavor(d, t, F::Verlet, averaging, 5.0); }});
        c.push_back({"flavor/" + a + "/verlet/middle", fpuChains, [=] {
                         F* f = flavor(d, t, F::Verlet, averaging, 5.0);
                         f->setThermostatPlacement(F::Middle);
                         return f;
                     }});
        c.push_back({"flavor/" + a + "/verlet/stiff-friction", fpuChains, [=] {
                         F* f = flavor(d, t, F::Verlet, averaging, 5.0);
                         f->setStiffFriction(true);
                         return f;
                     }});
        for (F::Scheme scheme : {F::Verlet, F::SymplecticEuler})
            c.push_back(
                {"flavor/" + a + (scheme == F::Verlet ? "/verlet" : "/euler") + "/exact-fast-flow", fpuChains, [=] {
                     F* f = flavor(d, t, scheme, averaging, 5.0);
                     f->setExactFastFlow(true);
                     return f;
                 }});
    }
    // Frozen distances beside System constraints and a virtual site.
    const double dm = 0.002, tm = 0.0005;
    c.push_back({"molecules/nonintrusive/verlet/langevin", bentMoleculesAndWater,
                 [=] { return flavor(dm, tm, F::Verlet, F::Nonintrusive, 5.0); }});
    c.push_back({"molecules/artificial/verlet", bentMoleculesAndWater,
                 [=] { return flavor(dm, tm, F::Verlet, F::Artificial); }});
    c.push_back({"molecules/artificial/euler/langevin", bentMoleculesAndWater,
                 [=] { return flavor(dm, tm, F::SymplecticEuler, F::Artificial, 5.0); }});
    c.push_back({"molecules/projected/verlet/langevin", bentMoleculesAndWater,
                 [=] { return flavor(dm, tm, F::Verlet, F::ArtificialProjected, 5.0); }});
    c.push_back({"molecules/projected/verlet/middle", bentMoleculesAndWater, [=] {
                     F* f = flavor(dm, tm, F::Verlet, F::ArtificialProjected, 5.0);
                     f->setThermostatPlacement(F::Middle);
                     return f;
                 }});
    // Stochastic impulse methods on the FPU chains, with and without friction.
    const vector<std::pair<S::Splitting, string>> splittings = {{S::LieTrotter, "lie-trotter"},
                                                                {S::Strang, "strang"},
                                                                {S::Yoshida4, "yoshida4"},
                                                                {S::Filtered, "filtered"},
                                                                {S::Warped, "warped"}};
    for (const auto& s : splittings)
        for (double friction : {0.0, 5.0}) {
            if (s.first == S::Yoshida4 && friction > 0)
                continue; // defined without friction only
            c.push_back({"sim/" + s.second + (friction > 0 ? "/langevin" : ""), fpuChains,
                         [=] { return impulse(0.02, s.first, friction); }});
        }
    for (S::Splitting splitting : {S::Filtered, S::Warped})
        c.push_back(
            {string("sim/") + (splitting == S::Filtered ? "filtered" : "warped") + "/middle/mode-bath", fpuChains, [=] {
                 S* s = impulse(0.02, splitting, 5.0);
                 s->setThermostatPlacement(S::Middle);
                 s->setStiffModeTemperature(10.0);
                 s->setStiffModeFriction(20.0);
                 return s;
             }});
    // Constrained cores carrying their Drude particles.
    for (const auto& s : splittings) {
        if (s.first == S::LieTrotter || s.first == S::Yoshida4)
            continue;
        c.push_back({"drude/" + s.second, drudeWater, [=] {
                         S* sim = impulse(0.001, s.first, 5.0);
                         sim->setStiffModeTemperature(1.0);
                         sim->setStiffModeFriction(20.0);
                         if (s.first == S::Filtered || s.first == S::Warped)
                             sim->setThermostatPlacement(S::Middle);
                         return sim;
                     }});
    }
    return c;
}

string hexFloat(double value) {
    char text[64];
    std::snprintf(text, sizeof(text), "%a", value);
    return text;
}

/** The lines a run leaves: "key particle x y z vx vy vz", each value as a hexadecimal float. */
vector<string> runCase(const Case& c, Platform& platform) {
    TestSystem t = c.makeSystem();
    std::unique_ptr<Integrator> integrator(c.makeIntegrator());
    Context context(*t.system, *integrator, platform);
    context.setPositions(t.positions);
    context.setVelocities(t.velocities);
    integrator->step(Steps);
    const vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
    vector<string> lines;
    for (size_t i = 0; i < q.size(); ++i) {
        std::ostringstream line;
        line << platform.getName() << ":" << c.name << " " << i;
        for (int d = 0; d < 3; ++d)
            line << " " << hexFloat(q[i][d]);
        for (int d = 0; d < 3; ++d)
            line << " " << hexFloat(v[i][d]);
        lines.push_back(line.str());
    }
    return lines;
}

const char* storedFile() {
    return FLAVORS_TEST_DATA_DIR "/stored_trajectories.txt";
}

} // namespace

TEST_P(StoredTrajectories, EverySchemeFollowsItsStoredTrajectoryBitForBit) {
    vector<string> produced;
    for (const Case& c : cases()) {
        const vector<string> lines = runCase(c, platform());
        produced.insert(produced.end(), lines.begin(), lines.end());
    }
    const string prefix = GetParam() + ":";
    if (const char* target = std::getenv("FLAVORS_WRITE_TRAJECTORIES")) {
        // Keep the other platform's lines, replace this platform's.
        vector<string> kept;
        std::ifstream old(target);
        for (string line; std::getline(old, line);)
            if (line.compare(0, prefix.size(), prefix) != 0)
                kept.push_back(line);
        old.close();
        std::ofstream out(target);
        for (const string& line : kept)
            out << line << "\n";
        for (const string& line : produced)
            out << line << "\n";
        GTEST_SKIP() << "wrote " << produced.size() << " lines to " << target;
    }
    std::map<string, string> stored;
    std::ifstream in(storedFile());
    ASSERT_TRUE(in.good()) << "cannot read " << storedFile();
    for (string line; std::getline(in, line);)
        if (line.compare(0, prefix.size(), prefix) == 0)
            stored[line.substr(0, line.find(' ', line.find(' ') + 1))] = line;
    ASSERT_FALSE(stored.empty()) << "no stored trajectories of " << GetParam() << " in " << storedFile();
    for (const string& line : produced) {
        const string key = line.substr(0, line.find(' ', line.find(' ') + 1));
        auto found = stored.find(key);
        ASSERT_NE(found, stored.end()) << "no stored line for " << key;
        EXPECT_EQ(found->second, line);
    }
}

TEST_P(StoredTrajectories, EverySchemeRewoundByLoadCheckpointRepeatsItsStepsBitForBit) {
    // 10 steps, a checkpoint, 15 steps; then the same Context loads the checkpoint and takes the 15 steps again, and so
    // does a new Context.  The new Context measures the stiff modes where its first step starts (the first Context
    // measured them at its start), so for a quadratic stiff group it follows to rounding, not bit for bit.
    for (const Case& c : cases()) {
        TestSystem t = c.makeSystem();
        std::unique_ptr<Integrator> integrator(c.makeIntegrator());
        Context context(*t.system, *integrator, platform());
        context.setPositions(t.positions);
        context.setVelocities(t.velocities);
        integrator->step(10);
        std::stringstream checkpoint;
        context.createCheckpoint(checkpoint);
        integrator->step(15);
        const vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
        context.loadCheckpoint(checkpoint);
        integrator->step(15);
        EXPECT_EQ(q, positionsOf(context)) << c.name;
        EXPECT_EQ(v, velocitiesOf(context)) << c.name;
        std::unique_ptr<Integrator> fresh(c.makeIntegrator());
        Context freshContext(*t.system, *fresh, platform());
        checkpoint.seekg(0);
        freshContext.loadCheckpoint(checkpoint);
        fresh->step(15);
        const double difference = relativeDifference(positionsOf(freshContext), q);
        EXPECT_LT(difference, 1e-12) << c.name;
        RecordProperty(c.name, std::to_string(difference));
    }
}

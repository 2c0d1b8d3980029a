// StochasticImpulseIntegrator::separateDrudeSprings: the System's energy and forces stay the same, the stiff group
// holds exactly the isotropic springs (energy, forces and normal-mode frequencies against formulas written here),
// the SIM takes the separated System and rejects the DrudeForce itself as stiff, bad input leaves the System as it
// was, and a short SIM run of the separated System stays finite on the original System's energy surface.

#include "ExpectRejected.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/DrudeForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/VerletIntegrator.h"
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::string;
using std::vector;

class ImpulseDrudeSprings : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseDrudeSprings);

namespace {

// 1/(4 pi eps0) in kJ nm/(mol e^2).
constexpr double Coulomb = 138.935457644382;
constexpr double Charge = -1.5, Alpha = 0.001; // e, nm^3: k = Coulomb q^2/alpha = 3.1e5 kJ/mol/nm^2
constexpr double DrudeMass = 0.4;

/**
 * Three Drude pairs: an isotropic one (core 0, Drude 1), a fully anisotropic one (core 2, Drude 3, axes 2-4 with
 * aniso12 = 0.7 and 5-6 with aniso34 = 1.2) and one with only its first axis (core 7, Drude 8, axis 7-4, aniso12 =
 * 1.3); Thole screening between the first and second and between the second and third.  The DrudeForce is in
 * SoftGroup with a tether on the other particles and a field on the Drude particles.  drudeOffset scales each Drude
 * particle's displacement from its core (0: on its core).
 */
struct SmallDrudeSystem {
    System system;
    vector<Vec3> positions;
    // Drude particle, core and the isotropic force constant Coulomb q^2/(alpha a3), a3 = 3 - a1 - a2, of each pair.
    struct Pair {
        int drude, core;
        double k;
    };
    vector<Pair> pairs;
    explicit SmallDrudeSystem(double drudeOffset = 1.0) {
        const double masses[] = {12.0 - DrudeMass, DrudeMass, 16.0 - DrudeMass, DrudeMass, 12.0, 1.0, 1.0,
                                 14.0 - DrudeMass, DrudeMass};
        for (double m : masses)
            system.addParticle(m);
        const Vec3 cores[] = {Vec3(0, 0, 0),          Vec3(0.14, 0.02, 0),     Vec3(0.25, -0.03, 0.01),
                              Vec3(0.10, 0.12, 0.03), Vec3(0.20, 0.10, -0.05), Vec3(-0.13, 0.04, 0.02)};
        const Vec3 offsets[] = {Vec3(0.004, -0.003, 0.002), Vec3(-0.002, 0.005, 0.003), Vec3(0.003, 0.002, -0.004)};
        positions = {cores[0],
                     cores[0] + offsets[0] * drudeOffset,
                     cores[1],
                     cores[1] + offsets[1] * drudeOffset,
                     cores[2],
                     cores[3],
                     cores[4],
                     cores[5],
                     cores[5] + offsets[2] * drudeOffset};
        DrudeForce* drude = new DrudeForce();
        drude->addParticle(1, 0, -1, -1, -1, Charge, Alpha, 0.0, 0.0);
        drude->addParticle(3, 2, 4, 5, 6, Charge, Alpha, 0.7, 1.2);
        drude->addParticle(8, 7, 4, -1, -1, Charge, Alpha, 1.3, 0.0);
        drude->addScreenedPair(0, 1, 2.6);
        drude->addScreenedPair(1, 2, 1.3);
        drude->setForceGroup(SoftGroup);
        system.addForce(drude);
        const double k = Coulomb * Charge * Charge / Alpha;
        pairs = {{1, 0, k}, {3, 2, k / (3 - 0.7 - 1.2)}, {8, 7, k / (3 - 1.3 - 1)}};
        CustomExternalForce* tether = new CustomExternalForce("0.5*5000*((x-x0)^2+(y-y0)^2+(z-z0)^2)");
        for (const char* p : {"x0", "y0", "z0"})
            tether->addPerParticleParameter(p);
        for (int i : {0, 2, 4, 5, 6, 7})
            tether->addParticle(i, {positions[i][0], positions[i][1], positions[i][2]});
        tether->setForceGroup(SoftGroup);
        system.addForce(tether);
        CustomExternalForce* field = new CustomExternalForce("-300*(x+0.5*y-0.2*z)");
        for (int i : {1, 3, 8})
            field->addParticle(i);
        field->setForceGroup(SoftGroup);
        system.addForce(field);
    }
};

struct Evaluation {
    double energy;
    vector<Vec3> forces;
};

Evaluation evaluate(const System& system, const vector<Vec3>& positions, Platform& platform,
                    const std::map<string, string>& properties, int groups = -1) {
    VerletIntegrator integrator(0.001);
    Context context(system, integrator, platform, properties);
    context.setPositions(positions);
    const State state = context.getState(State::Energy | State::Forces, false, groups);
    return {state.getPotentialEnergy(), state.getForces()};
}

double largestForce(const vector<Vec3>& forces) {
    double largest = 0;
    for (const Vec3& f : forces)
        largest = std::max(largest, std::sqrt(f.dot(f)));
    return largest;
}

bool finite(const vector<Vec3>& values) {
    for (const Vec3& v : values)
        if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
            return false;
    return true;
}

} // namespace

TEST_P(ImpulseDrudeSprings, SeparationKeepsEnergyAndForcesAndMovesExactlyTheIsotropicSprings) {
    for (double offset : {1.0, 0.0}) { // displaced Drude particles, and every Drude particle on its core
        SCOPED_TRACE("Drude offset " + std::to_string(offset));
        SmallDrudeSystem original(offset);
        SmallDrudeSystem separated(offset);
        const int forces = separated.system.getNumForces();
        StochasticImpulseIntegrator::separateDrudeSprings(separated.system, StiffGroup);
        ASSERT_EQ(forces + 2, separated.system.getNumForces()); // the springs, and their cancellation

        const Evaluation before = evaluate(original.system, original.positions, platform(), properties());
        const Evaluation after = evaluate(separated.system, separated.positions, platform(), properties());
        ASSERT_TRUE(finite(after.forces));
        const double scale = std::abs(before.energy) + 1.0;
        EXPECT_NEAR(before.energy, after.energy, 1e-10 * scale);
        double largest = 0;
        for (size_t i = 0; i < before.forces.size(); ++i) {
            const Vec3 d = after.forces[i] - before.forces[i];
            largest = std::max(largest, std::sqrt(d.dot(d)));
        }
        EXPECT_LE(largest, 1e-10 * largestForce(before.forces));

        // The stiff group is 0.5 k |d|^2 per pair with k = Coulomb q^2/(alpha a3), and its forces -k d on the Drude.
        // OpenCL keeps a HarmonicBondForce's k in single precision (6e-8 relative) even in double precision mode.
        const double parameterPrecision = isGpu() ? 1e-7 : 1e-10;
        const Evaluation stiff =
            evaluate(separated.system, separated.positions, platform(), properties(), 1 << StiffGroup);
        double expectedEnergy = 0;
        vector<Vec3> expectedForces(separated.positions.size());
        for (const SmallDrudeSystem::Pair& p : separated.pairs) {
            const Vec3 d = separated.positions[p.drude] - separated.positions[p.core];
            expectedEnergy += 0.5 * p.k * d.dot(d);
            expectedForces[p.drude] -= d * p.k;
            expectedForces[p.core] += d * p.k;
        }
        EXPECT_NEAR(expectedEnergy, stiff.energy, parameterPrecision * (expectedEnergy + 1.0));
        for (size_t i = 0; i < expectedForces.size(); ++i)
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(expectedForces[i][c], stiff.forces[i][c],
                            parameterPrecision * (largestForce(expectedForces) + 1.0))
                    << "particle " << i;
        if (offset != 0.0) {
            EXPECT_GT(expectedEnergy, 1.0); // the springs carry energy
        }
    }
}

TEST_P(ImpulseDrudeSprings, TheImpulseIntegratorTakesTheSeparatedSpringsAndRejectsTheDrudeForce) {
    // The DrudeForce itself as the stiff group: its anisotropic terms and screening are not quadratic.
    SmallDrudeSystem whole;
    for (int f = 0; f < whole.system.getNumForces(); ++f)
        if (dynamic_cast<DrudeForce*>(&whole.system.getForce(f)) != nullptr)
            whole.system.getForce(f).setForceGroup(StiffGroup);
    {
        StochasticImpulseIntegrator integrator(300, 5, 0.001, StiffMask);
        Context context(whole.system, integrator, platform(), properties());
        context.setPositions(whole.positions);
        expectRejected([&] { integrator.getStiffModeFrequencies(); }, {"not quadratic"});
    }
    // Separated: the stiff modes are the springs' relative motions, omega = sqrt(k/mu), three directions each.
    SmallDrudeSystem separated;
    StochasticImpulseIntegrator::separateDrudeSprings(separated.system, StiffGroup);
    StochasticImpulseIntegrator integrator(300, 5, 0.001, StiffMask);
    Context context(separated.system, integrator, platform(), properties());
    context.setPositions(separated.positions);
    vector<double> measured = integrator.getStiffModeFrequencies();
    measured.erase(std::remove_if(measured.begin(), measured.end(), [](double w) { return w < 1.0; }), measured.end());
    vector<double> expected;
    for (const SmallDrudeSystem::Pair& p : separated.pairs) {
        const double m1 = separated.system.getParticleMass(p.drude), m2 = separated.system.getParticleMass(p.core);
        for (int c = 0; c < 3; ++c)
            expected.push_back(std::sqrt(p.k * (m1 + m2) / (m1 * m2)));
    }
    std::sort(expected.begin(), expected.end());
    ASSERT_EQ(expected.size(), measured.size());
    for (size_t i = 0; i < expected.size(); ++i)
        EXPECT_NEAR(expected[i], measured[i], 1e-7 * expected[i]) << "mode " << i;
}

TEST_P(ImpulseDrudeSprings, BadInputIsRejectedAndLeavesTheSystemUnchanged) {
    SmallDrudeSystem drude;
    const int forces = drude.system.getNumForces();
    expectRejected([&] { StochasticImpulseIntegrator::separateDrudeSprings(drude.system, 32); },
                   {"separateDrudeSprings", "stiffGroup = 32", "0 to 31"});
    expectRejected([&] { StochasticImpulseIntegrator::separateDrudeSprings(drude.system, -1); },
                   {"stiffGroup = -1", "0 to 31"});
    expectRejected([&] { StochasticImpulseIntegrator::separateDrudeSprings(drude.system, SoftGroup); },
                   {"stiffGroup = " + std::to_string(SoftGroup), "group of the DrudeForce (force 0)"});
    EXPECT_EQ(forces, drude.system.getNumForces());

    System noDrude;
    noDrude.addParticle(1.0);
    noDrude.addForce(new HarmonicBondForce());
    expectRejected([&] { StochasticImpulseIntegrator::separateDrudeSprings(noDrude, StiffGroup); },
                   {"system = a System without a DrudeForce (1 forces)", "needs a DrudeForce"});
    EXPECT_EQ(1, noDrude.getNumForces());

    // 3 - aniso12 - aniso34 <= 0 leaves no isotropic spring: rejected before anything is added.
    SmallDrudeSystem flat;
    DrudeForce& flatDrude = dynamic_cast<DrudeForce&>(flat.system.getForce(0));
    flatDrude.setParticleParameters(1, 3, 2, 4, 5, 6, Charge, Alpha, 1.5, 1.5);
    expectRejected([&] { StochasticImpulseIntegrator::separateDrudeSprings(flat.system, StiffGroup); },
                   {"particle 1", "3 - aniso12 - aniso34 = 0", "above 0"});
    EXPECT_EQ(forces, flat.system.getNumForces());

    // A second call would cancel the isotropic springs twice.
    StochasticImpulseIntegrator::separateDrudeSprings(drude.system, StiffGroup);
    ASSERT_EQ(forces + 2, drude.system.getNumForces());
    const Evaluation once = evaluate(drude.system, drude.positions, platform(), properties());
    expectRejected([&] { StochasticImpulseIntegrator::separateDrudeSprings(drude.system, StiffGroup + 1); },
                   {"system = a System whose Drude springs are already separated", "once per System"});
    EXPECT_EQ(forces + 2, drude.system.getNumForces());
    const Evaluation after = evaluate(drude.system, drude.positions, platform(), properties());
    EXPECT_EQ(once.energy, after.energy);
}

TEST_P(ImpulseDrudeSprings, AShortImpulseRunStaysFiniteOnTheOriginalEnergySurface) {
    SmallDrudeSystem original;
    SmallDrudeSystem separated;
    StochasticImpulseIntegrator::separateDrudeSprings(separated.system, StiffGroup);
    StochasticImpulseIntegrator integrator(300, 5, 0.001, StiffMask);
    integrator.setStiffModeTemperature(1);
    integrator.setStiffModeFriction(20);
    integrator.setRandomNumberSeed(7);
    Context context(separated.system, integrator, platform(), properties());
    context.setPositions(separated.positions);
    context.setVelocitiesToTemperature(300, 3);
    integrator.step(500);
    const State state = context.getState(State::Positions | State::Energy | State::Forces);
    const vector<Vec3>& q = state.getPositions();
    ASSERT_TRUE(finite(q));
    // The Drude particles stay near their cores (cold Drudes: displacements of a few 0.001 nm).
    for (const SmallDrudeSystem::Pair& p : separated.pairs) {
        const Vec3 d = q[p.drude] - q[p.core];
        EXPECT_LT(std::sqrt(d.dot(d)), 0.02) << "Drude particle " << p.drude;
    }
    // The separated System's energy and forces where the run ended are the original System's.
    const Evaluation reference = evaluate(original.system, q, platform(), properties());
    EXPECT_NEAR(reference.energy, state.getPotentialEnergy(), 1e-10 * (std::abs(reference.energy) + 1.0));
    for (size_t i = 0; i < q.size(); ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(reference.forces[i][c], state.getForces()[i][c], 1e-10 * largestForce(reference.forces))
                << "particle " << i;
}

// The Middle thermostat placement of the Filtered and Warped splittings: the zero modes drift H/2, take one exact
// Ornstein-Uhlenbeck step and drift H/2, and report half-step velocities.  Without friction it is the Throughout step
// with the zero modes' velocities half a kick earlier; with friction a soft harmonic motion is sampled exactly in
// positions and velocities, where Throughout has them off by (Omega H)^2/12 and -(Omega H)^2/6.

#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <utility>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseMiddle : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseMiddle);

namespace {

constexpr double CoreMass = 15.6, DrudeMass = 0.4, FreeMass = 12.0;

/**
 * Drude-like pairs (particles 2c, 2c + 1; omega_rel = 1000/ps, StiffGroup) and free particles after them, all in a
 * soft potential a m |q|^2/2 + b |q|^4 (a = Omega^2: harmonic motion of frequency Omega when b = 0).
 */
System* pairsAndFreeParticles(int pairs, int free, double omegaSquared, double quartic) {
    System* system = new System();
    HarmonicBondForce* springs = new HarmonicBondForce();
    springs->setForceGroup(StiffGroup);
    CustomExternalForce* soft = new CustomExternalForce("0.5*a*m*(x^2+y^2+z^2)+b*(x^4+y^4+z^4)");
    soft->addGlobalParameter("a", omegaSquared);
    soft->addGlobalParameter("b", quartic);
    soft->addPerParticleParameter("m");
    const double mu = CoreMass * DrudeMass / (CoreMass + DrudeMass);
    for (int c = 0; c < pairs; ++c) {
        system->addParticle(CoreMass);
        system->addParticle(DrudeMass);
        springs->addBond(2 * c, 2 * c + 1, 0.0, mu * 1e6);
        soft->addParticle(2 * c, {CoreMass});
        soft->addParticle(2 * c + 1, {DrudeMass});
    }
    for (int i = 0; i < free; ++i) {
        system->addParticle(FreeMass);
        soft->addParticle(2 * pairs + i, {FreeMass});
    }
    system->addForce(springs);
    system->addForce(soft);
    return system;
}

/** The zero modes' share of the half kick (H/2) M^-1 F: per pair its centre-of-mass part, per free particle all. */
vector<Vec3> zeroModeHalfKick(const vector<Vec3>& forces, int pairs, double H) {
    vector<Vec3> kick(forces.size());
    for (int c = 0; c < pairs; ++c)
        kick[2 * c] = kick[2 * c + 1] = (forces[2 * c] + forces[2 * c + 1]) * (0.5 * H / (CoreMass + DrudeMass));
    for (size_t i = 2 * pairs; i < forces.size(); ++i)
        kick[i] = forces[i] * (0.5 * H / FreeMass);
    return kick;
}

/** <v^2>/kT and <Omega^2 x^2>/kT at the step ends of K(H/2) E(H) K(H/2), E the exact free flow with friction gamma. */
std::pair<double, double> throughoutHarmonicStatistics(double omega, double H, double gamma) {
    const double e = std::exp(-gamma * H);
    const double flow[2][2] = {{1, (1 - e) / gamma}, {0, e}};
    const double noise[2][2] = {{(2 * gamma * H - 3 + 4 * e - e * e) / (gamma * gamma), (1 - e) * (1 - e) / gamma},
                                {(1 - e) * (1 - e) / gamma, 1 - e * e}};
    const double kick[2][2] = {{1, 0}, {-0.5 * H * omega * omega, 1}};
    auto product = [](const double(&a)[2][2], const double(&b)[2][2], double(&out)[2][2]) {
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j)
                out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
    };
    double half[2][2], step[2][2], source[2][2], kickT[2][2] = {{1, kick[1][0]}, {0, 1}}, tmp[2][2];
    product(kick, flow, half);
    product(half, kick, step);
    product(kick, noise, tmp);
    product(tmp, kickT, source);
    double c[2][2] = {{1, 0}, {0, 1}};
    for (int n = 0; n < 200000; ++n) {
        double next[2][2], stepT[2][2] = {{step[0][0], step[1][0]}, {step[0][1], step[1][1]}};
        product(step, c, tmp);
        product(tmp, stepT, next);
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j)
                c[i][j] = next[i][j] + source[i][j];
    }
    return {c[1][1], omega * omega * c[0][0]};
}

} // namespace

TEST_P(ImpulseMiddle, WithoutFrictionItIsThroughoutWithTheZeroModesHalfAKickEarlier) {
    // Pairs and free particles in an anharmonic soft potential, Warped and Filtered without friction, H = 2 fs.  The
    // Middle run starts from the Throughout run's on-step velocities less the zero modes' half kick; after 50 steps
    // both have the same positions and the Middle velocities are the Throughout ones less the zero modes' half kick
    // at the final positions (the stiff modes' velocities agree).
    const int pairs = 3, free = 3;
    const double H = 0.002;
    std::unique_ptr<System> system(pairsAndFreeParticles(pairs, free, 300.0 * 300.0, 2e4));
    vector<Vec3> q0, v0;
    for (int i = 0; i < 2 * pairs + free; ++i) {
        q0.push_back(Vec3(0.01 * i - 0.03, 0.02 - 0.005 * i, 0.013 * (i % 3)) + (i % 2 ? Vec3(0.003, 0, 0) : Vec3()));
        v0.push_back(Vec3(0.3 - 0.1 * i, 0.2 * (i % 2), -0.15 + 0.05 * i));
    }
    for (auto splitting : {StochasticImpulseIntegrator::Warped, StochasticImpulseIntegrator::Filtered}) {
        SCOPED_TRACE(splitting == StochasticImpulseIntegrator::Warped ? "Warped" : "Filtered");
        StochasticImpulseIntegrator throughout(0.0, 0.0, H, StiffMask), middle(0.0, 0.0, H, StiffMask);
        throughout.setSplitting(splitting);
        middle.setSplitting(splitting);
        middle.setThermostatPlacement(StochasticImpulseIntegrator::Middle);
        Context a(*system, throughout, platform(), properties()), b(*system, middle, platform(), properties());
        a.setPositions(q0);
        a.setVelocities(v0);
        b.setPositions(q0);
        const int softMask = ~StiffMask;
        const vector<Vec3> kick0 = zeroModeHalfKick(a.getState(State::Forces, false, softMask).getForces(), pairs, H);
        vector<Vec3> v0Middle(v0);
        for (size_t i = 0; i < v0.size(); ++i)
            v0Middle[i] -= kick0[i];
        b.setVelocities(v0Middle);
        throughout.step(50);
        middle.step(50);
        const vector<Vec3> qa = positionsOf(a), qb = positionsOf(b), va = velocitiesOf(a), vb = velocitiesOf(b);
        const vector<Vec3> kick = zeroModeHalfKick(b.getState(State::Forces, false, softMask).getForces(), pairs, H);
        for (size_t i = 0; i < qa.size(); ++i) {
            const Vec3 dq = qa[i] - qb[i], dv = va[i] - kick[i] - vb[i];
            EXPECT_LT(std::sqrt(dq.dot(dq)), 1e-12) << "particle " << i;
            EXPECT_LT(std::sqrt(dv.dot(dv)), 1e-9) << "particle " << i;
            // The half kick is far from negligible here.
            EXPECT_GT(std::sqrt(kick[i].dot(kick[i])), 1e-4) << "particle " << i;
        }
    }
}

TEST_P(ImpulseMiddle, ASoftHarmonicMotionIsSampledExactly) {
    // 1000 free particles and 500 pairs in a soft harmonic well with Omega H = 1 (Omega = 500/ps, H = 2 fs), 300 K at
    // 20/ps, Warped.  Sampled every 25 steps (one friction time) over 100 frames after 1000 steps: Middle's
    // <m v^2>/kT and <m Omega^2 x^2>/kT of the free particles and the pairs' centres of mass are 1 within 5 standard
    // errors of the frame means; Throughout's are those of its linear map (0.83 and 1.11, computed in the test).
    const int pairs = 500, free = 1000;
    const double omega = 500, H = 0.002, gamma = 20, temperature = 300, kT = BOLTZ * temperature;
    std::unique_ptr<System> system(pairsAndFreeParticles(pairs, free, omega * omega, 0.0));
    const std::pair<double, double> throughoutExpected = throughoutHarmonicStatistics(omega, H, gamma);
    // 1 - (Omega H)^2/6 and 1 + (Omega H)^2/12 to leading order; at Omega H = 1 the map gives 0.83 and 1.11.
    EXPECT_NEAR(0.833, throughoutExpected.first, 0.005);
    EXPECT_NEAR(1.111, throughoutExpected.second, 0.005);
    for (auto placement : {StochasticImpulseIntegrator::Middle, StochasticImpulseIntegrator::Throughout}) {
        SCOPED_TRACE(placement == StochasticImpulseIntegrator::Middle ? "Middle" : "Throughout");
        StochasticImpulseIntegrator integrator(temperature, gamma, H, StiffMask);
        integrator.setSplitting(StochasticImpulseIntegrator::Warped);
        integrator.setThermostatPlacement(placement);
        integrator.setRandomNumberSeed(21);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(vector<Vec3>(2 * pairs + free));
        context.setVelocities(vector<Vec3>(2 * pairs + free));
        integrator.step(1000);
        vector<double> velocityFrames, positionFrames;
        for (int frame = 0; frame < 100; ++frame) {
            integrator.step(25);
            const vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
            double sv = 0, sx = 0;
            auto add = [&](double mass, const Vec3& x, const Vec3& u) {
                sv += mass * u.dot(u) / (3 * kT);
                sx += mass * omega * omega * x.dot(x) / (3 * kT);
            };
            for (int c = 0; c < pairs; ++c) {
                const double m = CoreMass + DrudeMass;
                add(m, (q[2 * c] * CoreMass + q[2 * c + 1] * DrudeMass) / m,
                    (v[2 * c] * CoreMass + v[2 * c + 1] * DrudeMass) / m);
            }
            for (int i = 2 * pairs; i < 2 * pairs + free; ++i)
                add(FreeMass, q[i], v[i]);
            velocityFrames.push_back(sv / (pairs + free));
            positionFrames.push_back(sx / (pairs + free));
        }
        auto meanAndError = [](const vector<double>& values) {
            double mean = 0, square = 0;
            for (double x : values)
                mean += x / values.size();
            for (double x : values)
                square += (x - mean) * (x - mean) / (values.size() - 1);
            return std::make_pair(mean, std::sqrt(square / values.size()));
        };
        const auto v = meanAndError(velocityFrames), x = meanAndError(positionFrames);
        const double expectedV = placement == StochasticImpulseIntegrator::Middle ? 1.0 : throughoutExpected.first;
        const double expectedX = placement == StochasticImpulseIntegrator::Middle ? 1.0 : throughoutExpected.second;
        EXPECT_NEAR(expectedV, v.first, 5 * v.second);
        EXPECT_NEAR(expectedX, x.first, 5 * x.second);
        // The bound separates the placements: 5 standard errors are far below their difference of 8 to 17 %.
        EXPECT_LT(5 * std::max(v.second, x.second), 0.04);
    }
}

TEST_P(ImpulseMiddle, NeedsFilteredOrWarpedAndTheContextStaysUsable) {
    std::unique_ptr<System> system(pairsAndFreeParticles(1, 1, 1e4, 0.0));
    StochasticImpulseIntegrator integrator(300.0, 5.0, 0.002, StiffMask);
    integrator.setThermostatPlacement(StochasticImpulseIntegrator::Middle);
    Context context(*system, integrator, platform(), properties());
    context.setPositions({Vec3(), Vec3(0.001, 0, 0), Vec3(0.1, 0, 0)});
    try {
        integrator.step(1);
        FAIL() << "Middle with Strang was not rejected";
    } catch (const OpenMMException& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("thermostatPlacement = Middle (1)"), std::string::npos) << message;
        EXPECT_NE(message.find("Warped (4)"), std::string::npos) << message;
    }
    EXPECT_EQ(0, context.getState(State::Positions).getStepCount());
    integrator.setSplitting(StochasticImpulseIntegrator::Warped);
    integrator.step(3);
    EXPECT_EQ(3, context.getState(State::Positions).getStepCount());
    integrator.setSplitting(StochasticImpulseIntegrator::Strang);
    integrator.setThermostatPlacement(StochasticImpulseIntegrator::Throughout);
    integrator.step(1);
    EXPECT_EQ(4, context.getState(State::Positions).getStepCount());
    EXPECT_THROW(integrator.setThermostatPlacement((StochasticImpulseIntegrator::ThermostatPlacement)2),
                 OpenMMException);
    EXPECT_EQ(StochasticImpulseIntegrator::Throughout, integrator.getThermostatPlacement());
}

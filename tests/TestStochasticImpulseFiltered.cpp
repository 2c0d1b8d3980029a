// The splittings without the impulse bias, Filtered and Warped: a constant soft force gives every stiff mode its exact
// mean displacement (where Strang gives (omega H/2) cot(omega H/2) of it), second order on a smooth problem, no
// resonance spike at omega H = 2 pi on the FPU chain, processed velocities (exact for a steadily changing force,
// forgotten when the state is set), each one's stability threshold under a soft force that is stiff itself, and the
// Warped phase limit (setMaxWarpedPhase): the exact mean and processed velocities kept, stable past Warped's own limit.

#include "ExpectRejected.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomCompoundBondForce.h"
#include "openmm/serialization/XmlSerializer.h"
#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseFiltered : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseFiltered);

namespace {

constexpr double Pi = 3.14159265358979323846;

const StochasticImpulseIntegrator::Splitting BiasFree[] = {StochasticImpulseIntegrator::Filtered,
                                                           StochasticImpulseIntegrator::Warped};

std::string nameOf(StochasticImpulseIntegrator::Splitting splitting) {
    return splitting == StochasticImpulseIntegrator::Filtered ? "Filtered"
           : splitting == StochasticImpulseIntegrator::Warped ? "Warped"
                                                              : "Strang";
}

/** A bias-free step: Filtered, Warped, or Warped with its phase per step limited (setMaxWarpedPhase). */
struct BiasFreeStep {
    StochasticImpulseIntegrator::Splitting splitting;
    double maxWarpedPhase;
    std::string name() const {
        return nameOf(splitting) + (maxWarpedPhase > 0 ? " limited to " + std::to_string(maxWarpedPhase) : "");
    }
    void configure(StochasticImpulseIntegrator& integrator) const {
        integrator.setSplitting(splitting);
        integrator.setMaxWarpedPhase(maxWarpedPhase);
    }
};

// The limit 1.2 is below the warped turn at omega H > 1.3 (H > 1.3 fs for a Drude pair), so it acts at H = 2 fs.
const BiasFreeStep BiasFreeSteps[] = {{StochasticImpulseIntegrator::Filtered, 0.0},
                                      {StochasticImpulseIntegrator::Warped, 0.0},
                                      {StochasticImpulseIntegrator::Warped, 1.2}};

/** The warped xi~ of omega H = xi without friction: xi~ tan(xi~/2) = xi^2/2 (bisection on (0, pi)). */
double warpedTurn(double xi) {
    double lo = 0.0, hi = Pi;
    for (int i = 0; i < 200; ++i)
        (0.5 * (lo + hi) * std::tan(0.25 * (lo + hi)) < 0.5 * xi * xi ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
}

/**
 * One particle of mass m on a stiff isotropic tether k |q - q0|^2/2 (one stiff mode per direction, omega^2 = k/m, no
 * zero mode; q0 = 0 unless given), pushed by the constant soft force F.  Its exact equilibrium is q* = q0 + F/k.
 */
struct TetheredParticle {
    static constexpr double Mass = 2.0;
    const Vec3 force{30.0, -12.0, 5.0};
    System system;
    double k;
    Vec3 minimum;
    explicit TetheredParticle(double omega, const Vec3& minimum = Vec3()) : k(Mass * omega * omega), minimum(minimum) {
        system.addParticle(Mass);
        CustomExternalForce* tether = new CustomExternalForce("0.5*k*((x-x0)^2+(y-y0)^2+(z-z0)^2)");
        tether->addGlobalParameter("k", k);
        tether->addPerParticleParameter("x0");
        tether->addPerParticleParameter("y0");
        tether->addPerParticleParameter("z0");
        tether->addParticle(0, {minimum[0], minimum[1], minimum[2]});
        tether->setForceGroup(StiffGroup);
        CustomExternalForce* push = new CustomExternalForce("-(fx*x+fy*y+fz*z)");
        push->addGlobalParameter("fx", force[0]);
        push->addGlobalParameter("fy", force[1]);
        push->addGlobalParameter("fz", force[2]);
        push->addParticle(0);
        system.addForce(tether);
        system.addForce(push);
    }
    Vec3 equilibrium() const { return minimum + force / k; }
};

/** |q - expected| / |expected| and |v| / (omega |expected|) after steps from (q0, 0). */
std::pair<double, double> driftFrom(const TetheredParticle& p, StochasticImpulseIntegrator& integrator,
                                    Platform& platform, const std::map<std::string, std::string>& properties,
                                    const Vec3& q0, const Vec3& expected, double omega, int steps) {
    Context context(p.system, integrator, platform, properties);
    context.setPositions({q0});
    context.setVelocities({Vec3()});
    integrator.step(steps);
    const Vec3 dq = positionsOf(context)[0] - expected, v = velocitiesOf(context)[0];
    const double scale = std::sqrt(expected.dot(expected));
    return {std::sqrt(dq.dot(dq)) / scale, std::sqrt(v.dot(v)) / (omega * scale)};
}

} // namespace

TEST_P(ImpulseFiltered, ConstantSoftForceGivesTheExactMeanDisplacement) {
    // omega H from 0.1 to 10 with H = 0.01 ps.  Filtered: the exact equilibrium (F/k, 0) is a fixed point without
    // friction, and with friction (gamma = omega/5, temperature 0) every start converges to the state (F/k, 0); the
    // mean of a noisy run is the same by linearity.  The method says where it cannot: its filter has a pole where the
    // damped mode turns by an odd multiple of pi per step (omega H = pi, 3 pi here; skipped), and at omega H = 2 pi k
    // without friction the filter vanishes and every state is a fixed point (only the friction case is checked there).
    // Strang's fixed point is (F/k) (omega H/2) cot(omega H/2), with zero velocity (it has none at omega H = pi k).
    const double H = 0.01;
    for (double xi : {0.1, 0.5, 1.0, 2.0, 3.0, Pi, 4.0, 5.0, 2 * Pi - 0.3, 2 * Pi, 7.0, 8.0, 3 * Pi, 10.0}) {
        const double omega = xi / H;
        TetheredParticle p(omega);
        const Vec3 exact = p.equilibrium();
        const bool resonant = std::abs(std::remainder(xi, 2 * Pi)) < 1e-12;
        const bool pole = std::abs(std::remainder(xi + Pi, 2 * Pi)) < 0.05;
        if (!resonant && !pole) {
            StochasticImpulseIntegrator filtered(0.0, 0.0, H, StiffMask);
            filtered.setSplitting(StochasticImpulseIntegrator::Filtered);
            const auto drift = driftFrom(p, filtered, platform(), properties(), exact, exact, omega, 30);
            EXPECT_LT(drift.first, 1e-10) << "Filtered, no friction, omega H = " << xi;
            EXPECT_LT(drift.second, 1e-10) << "Filtered, no friction, omega H = " << xi;
        }
        if (!pole) {
            // Friction omega/5: amplitudes decay as exp(-omega t/10), by exp(-28) after 280/xi steps.
            StochasticImpulseIntegrator damped(0.0, 0.2 * omega, H, StiffMask);
            damped.setSplitting(StochasticImpulseIntegrator::Filtered);
            const int steps = (int)std::ceil(280 / xi);
            const auto converged = driftFrom(p, damped, platform(), properties(), Vec3(), exact, omega, steps);
            EXPECT_LT(converged.first, 1e-9) << "Filtered with friction, omega H = " << xi;
            // Its velocity at the step's end is processed to the exact 0 below omega H = 0.9 pi (unprocessed it is
            // lambda F with lambda omega^2 = 0.04 to 2.3 at omega H = 0.1 to 2.8 here).
            if (xi < 0.9 * Pi) {
                EXPECT_LT(converged.second, 1e-9) << "Filtered with friction, omega H = " << xi;
            }
        }
        {
            // Warped: no pole and no resonance; the warped mode turns by less than pi per step at every xi.
            StochasticImpulseIntegrator warped(0.0, 0.0, H, StiffMask);
            warped.setSplitting(StochasticImpulseIntegrator::Warped);
            const auto drift = driftFrom(p, warped, platform(), properties(), exact, exact, omega, 30);
            EXPECT_LT(drift.first, 1e-10) << "Warped, no friction, omega H = " << xi;
            EXPECT_LT(drift.second, 1e-10) << "Warped, no friction, omega H = " << xi;
            // With friction omega/5 the warped mode decays as exp(-omega t/10) too.
            StochasticImpulseIntegrator damped(0.0, 0.2 * omega, H, StiffMask);
            damped.setSplitting(StochasticImpulseIntegrator::Warped);
            const int steps = (int)std::ceil(280 / xi);
            const auto converged = driftFrom(p, damped, platform(), properties(), Vec3(), exact, omega, steps);
            EXPECT_LT(converged.first, 1e-9) << "Warped with friction, omega H = " << xi;
            // Processed velocities where the warped mode turns by less than 0.9 pi (xi below about 6).
            if (warpedTurn(xi) < 0.85 * Pi) {
                EXPECT_LT(converged.second, 1e-9) << "Warped with friction, omega H = " << xi;
            }
        }
        for (double maxPhase : {0.5, 1.2, 3.0}) {
            // Warped with its phase per step limited: where the limit acts, the slowed flow's kicks are scaled to keep
            // the exact mean.  The same fixed point, converged with friction, and processed velocities (the limited
            // mode turns by less than 0.9 pi).
            SCOPED_TRACE("Warped limited to " + std::to_string(maxPhase));
            StochasticImpulseIntegrator limited(0.0, 0.0, H, StiffMask);
            limited.setSplitting(StochasticImpulseIntegrator::Warped);
            limited.setMaxWarpedPhase(maxPhase);
            const auto drift = driftFrom(p, limited, platform(), properties(), exact, exact, omega, 30);
            EXPECT_LT(drift.first, 1e-10) << "no friction, omega H = " << xi;
            EXPECT_LT(drift.second, 1e-10) << "no friction, omega H = " << xi;
            // Friction omega/5 in a mode slowed to omega~ (damping ratio 0.1 omega/omega~, overdamped where the limit
            // slows it below omega/20): amplitudes decay at least as exp(-omega~ t/10) below that, and as
            // exp(-omega~^2 t/(0.2 omega)) above it; enough steps for exp(-28).
            StochasticImpulseIntegrator damped(0.0, 0.2 * omega, H, StiffMask);
            damped.setSplitting(StochasticImpulseIntegrator::Warped);
            damped.setMaxWarpedPhase(maxPhase);
            const double slowest = std::min(warpedTurn(xi), maxPhase);
            const double rate = slowest > 0.05 * xi ? 0.1 * slowest : slowest * slowest / (0.2 * xi);
            const int steps = (int)std::ceil(28 / rate);
            const auto converged = driftFrom(p, damped, platform(), properties(), Vec3(), exact, omega, steps);
            EXPECT_LT(converged.first, 1e-9) << "with friction, omega H = " << xi;
            if (std::min(warpedTurn(xi), maxPhase) < 0.85 * Pi) {
                EXPECT_LT(converged.second, 1e-9) << "with friction, omega H = " << xi;
            }
        }
        if (std::abs(std::remainder(xi, Pi)) > 1e-12) {
            const double bias = 0.5 * xi / std::tan(0.5 * xi);
            StochasticImpulseIntegrator strang(0.0, 0.0, H, StiffMask);
            const auto strangDrift =
                driftFrom(p, strang, platform(), properties(), exact * bias, exact * bias, omega, 30);
            EXPECT_LT(strangDrift.first, 1e-9 / std::min(1.0, std::abs(bias))) << "Strang, omega H = " << xi;
            EXPECT_LT(strangDrift.second, 1e-9 / std::min(1.0, std::abs(bias))) << "Strang, omega H = " << xi;
            // The two differ: Strang's fixed point is off the exact one by 1 - bias (at least 8e-4 here).
            EXPECT_GT(std::abs(1 - bias), 8e-4);
        }
    }
}

TEST_P(ImpulseFiltered, WarpedKeepsTheMinimumOfTheStiffPotential) {
    // A tether whose minimum q0 is away from the origin (a constant stiff force k q0 in U = q^T K q/2 - b^T q) and a
    // constant soft force F: the exact equilibrium q0 + F/k is Warped's fixed point, with and without friction, at
    // omega H = 2.59.  Warped scales b with the flow's (omega~/omega)^2; unscaled, the point would sit at
    // q0 (omega/omega~)^2 + F/k, 0.6 q0 away.
    const double omega = 1036, H = 0.0025;
    TetheredParticle p(omega, Vec3(0.02, -0.01, 0.015));
    const Vec3 exact = p.equilibrium();
    for (double friction : {0.0, 20.0}) {
        SCOPED_TRACE(friction);
        StochasticImpulseIntegrator integrator(0.0, friction, H, StiffMask);
        integrator.setSplitting(StochasticImpulseIntegrator::Warped);
        const int steps = friction > 0 ? 2000 : 30;
        const auto drift =
            driftFrom(p, integrator, platform(), properties(), friction > 0 ? Vec3() : exact, exact, omega, steps);
        EXPECT_LT(drift.first, 1e-9);
    }
}

TEST_P(ImpulseFiltered, DrudePairWithFrictionReachesTheSelfConsistentDisplacement) {
    // A core (15.2) and a Drude particle (0.4) on a spring with omega_rel = 1036/ps, a constant force F on the Drude
    // particle only (a field on its charge): the pair's centre of mass is a zero mode (driven, at 300 K with 5/ps)
    // and the relative coordinate's exact mean is F mu / (m_D k).  H = 2 fs (omega H = 2.07) with the relative mode
    // at 0 K and 20/ps: after 4 ps the relative coordinate is F mu / (m_D k) to 1e-9, where Strang gives 0.6 of it.
    const double mCore = 15.2, mDrude = 0.4, mu = mCore * mDrude / (mCore + mDrude), omega = 1036,
                 k = mu * omega * omega;
    const Vec3 field(20.0, -5.0, 8.0);
    System system;
    system.addParticle(mCore);
    system.addParticle(mDrude);
    HarmonicBondForce* spring = new HarmonicBondForce();
    spring->addBond(0, 1, 0.0, k);
    spring->setForceGroup(StiffGroup);
    CustomExternalForce* push = new CustomExternalForce("-(fx*x+fy*y+fz*z)");
    push->addGlobalParameter("fx", field[0]);
    push->addGlobalParameter("fy", field[1]);
    push->addGlobalParameter("fz", field[2]);
    push->addParticle(1);
    system.addForce(spring);
    system.addForce(push);
    const Vec3 exact = field * (mu / (mDrude * k));
    for (auto splitting : {StochasticImpulseIntegrator::Filtered, StochasticImpulseIntegrator::Warped,
                           StochasticImpulseIntegrator::Strang}) {
        SCOPED_TRACE(nameOf(splitting));
        StochasticImpulseIntegrator integrator(300.0, 5.0, 0.002, StiffMask);
        integrator.setSplitting(splitting);
        integrator.setStiffModeTemperature(0.0);
        integrator.setStiffModeFriction(20.0);
        integrator.setRandomNumberSeed(3);
        Context context(system, integrator, platform(), properties());
        context.setPositions({Vec3(), Vec3()});
        integrator.step(2000);
        const vector<Vec3> q = positionsOf(context);
        const Vec3 r = q[1] - q[0];
        const double ratio = r.dot(exact) / exact.dot(exact);
        const Vec3 off = r - exact * ratio;
        EXPECT_LT(std::sqrt(off.dot(off)), 1e-9 * std::sqrt(exact.dot(exact)));
        if (splitting != StochasticImpulseIntegrator::Strang)
            EXPECT_NEAR(1.0, ratio, 1e-9);
        else
            EXPECT_NEAR(0.5 * omega * 0.002 / std::tan(0.5 * omega * 0.002), ratio, 0.01);
    }
}

TEST_P(ImpulseFiltered, SecondOrderOnASmoothProblem) {
    // The FPU chain with omega = 10 (omega H <= 0.125: the smooth regime), no friction, positions at t = 1 ps against
    // Yoshida4 with H = 1/4096 (error ~1e-13).  Halving H from 1/160 to 1/320 must divide the error by 2^p with
    // p = 2 +- 0.15.
    std::unique_ptr<System> system(fpuSystem(3, 10.0));
    const vector<Vec3> q0 = fpuPositions({-0.4, 0.1, 0.35}, {0.02, -0.03, 0.01});
    const vector<Vec3> v0 = {Vec3(0.3, 0, 0),  Vec3(-0.2, 0, 0), Vec3(0.5, 0, 0),
                             Vec3(-0.4, 0, 0), Vec3(0.1, 0, 0),  Vec3(0.25, 0, 0)};
    auto run = [&](StochasticImpulseIntegrator::Splitting splitting, int stepsPerPs) {
        StochasticImpulseIntegrator integrator(0.0, 0.0, 1.0 / stepsPerPs, StiffMask);
        integrator.setSplitting(splitting);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(q0);
        context.setVelocities(v0);
        integrator.step(stepsPerPs);
        return positionsOf(context);
    };
    const vector<Vec3> reference = run(StochasticImpulseIntegrator::Yoshida4, 4096);
    for (auto splitting : BiasFree) {
        auto error = [&](int stepsPerPs) {
            const vector<Vec3> q = run(splitting, stepsPerPs);
            double worst = 0;
            for (size_t i = 0; i < q.size(); ++i)
                worst = std::max(worst, std::abs(q[i][0] - reference[i][0]));
            return worst;
        };
        const double coarse = error(160), fine = error(320);
        const double order = std::log2(coarse / fine);
        EXPECT_NEAR(2.0, order, 0.15) << nameOf(splitting) << ": errors " << coarse << " and " << fine;
        EXPECT_GT(fine, 1e-9); // far above the reference's own error
    }
}

TEST_P(ImpulseFiltered, NoResonanceSpikeOnTheFpuChainAtOmegaHTwoPi) {
    // The FPU chain (omega = 50), no friction, 20 ps: the largest total-energy error over the run at omega H within
    // 0.3 of 2 pi.  Strang resonates there (errors of several kJ/mol, far above its 0.6 at omega H = 5 and 7.5);
    // Filtered's filters vanish at 2 pi: its error there must stay below its own error at omega H = 5 and 7.5.  (Warped
    // is not checked here: its modes turn by less than pi per step at every omega H, TestExactModeFlow, and it does not
    // keep this energy, whose stiff springs it runs at omega~: 3 to 34 kJ/mol at omega H = 1 to 8.)
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    const vector<Vec3> q0 = fpuPositions({-0.4, 0.1, 0.35}, {0.02, -0.03, 0.01});
    const vector<Vec3> v0 = {Vec3(0.3, 0, 0),  Vec3(-0.2, 0, 0), Vec3(0.5, 0, 0),
                             Vec3(-0.4, 0, 0), Vec3(0.1, 0, 0),  Vec3(0.25, 0, 0)};
    auto energyError = [&](StochasticImpulseIntegrator::Splitting splitting, double xi) {
        const double H = xi / 50.0;
        StochasticImpulseIntegrator integrator(0.0, 0.0, H, StiffMask);
        integrator.setSplitting(splitting);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(q0);
        context.setVelocities(v0);
        auto energy = [&] {
            State s = context.getState(State::Energy);
            return s.getPotentialEnergy() + s.getKineticEnergy();
        };
        const double e0 = energy();
        double worst = 0;
        for (int step = 0; step < (int)(20.0 / H); ++step) {
            integrator.step(1);
            worst = std::max(worst, std::abs(energy() - e0));
        }
        return worst;
    };
    for (auto splitting : {StochasticImpulseIntegrator::Filtered, StochasticImpulseIntegrator::Strang}) {
        SCOPED_TRACE(nameOf(splitting));
        const double away = std::max(energyError(splitting, 5.0), energyError(splitting, 7.5));
        double nearResonance = 0;
        for (double xi : {2 * Pi - 0.3, 2 * Pi - 0.1, 2 * Pi, 2 * Pi + 0.1, 2 * Pi + 0.3})
            nearResonance = std::max(nearResonance, energyError(splitting, xi));
        if (splitting != StochasticImpulseIntegrator::Strang)
            EXPECT_LT(nearResonance, away) << "near 2 pi " << nearResonance << ", away " << away;
        else
            EXPECT_GT(nearResonance, 5 * away) << "near 2 pi " << nearResonance << ", away " << away;
    }
}

TEST_P(ImpulseFiltered, SteadilyGrowingSoftForceGivesTheExactVelocity) {
    // A tethered particle (m = 2, omega = 1036/ps, friction 20/ps at 0 K) pulled by a soft force c r_d(t) towards a
    // driver particle that drifts at constant velocity V (mass 1e12, no friction: its speed changes by 1e-9 of itself),
    // so the force grows steadily, G = c V.  The exact motion settles on x = (c r_d - gamma m G/k)/k, v = G/k.  The
    // Filtered and Warped steps' positions follow it; their unprocessed velocities at the step's end would be c' G/k
    // with c' = 1.20, 2.36, 4.94 (Filtered) and 1.18, 1.80, 2.30 (Warped) at omega H = 1.04, 2.07, 2.59 (plus lambda F
    // with friction).  Processed, they are G/k.
    const double mass = 2.0, omega = 1036.0, k = mass * omega * omega, gamma = 20.0, coupling = 3e4;
    const Vec3 driverVelocity(1.0, -0.4, 0.2), growth = driverVelocity * coupling;
    System system;
    system.addParticle(mass);
    system.addParticle(1e12);
    CustomExternalForce* tether = new CustomExternalForce("0.5*k*(x^2+y^2+z^2)");
    tether->addGlobalParameter("k", k);
    tether->addParticle(0);
    tether->setForceGroup(StiffGroup);
    system.addForce(tether);
    CustomCompoundBondForce* pull = new CustomCompoundBondForce(2, "-c*(x1*x2+y1*y2+z1*z2)");
    pull->addGlobalParameter("c", coupling);
    pull->addBond({0, 1});
    system.addForce(pull);
    for (const BiasFreeStep& variant : BiasFreeSteps)
        for (double H : {0.001, 0.002, 0.0025}) {
            SCOPED_TRACE(variant.name() + ", H = " + std::to_string(H));
            StochasticImpulseIntegrator integrator(0.0, 0.0, H, StiffMask);
            variant.configure(integrator);
            integrator.setStiffModeTemperature(0.0);
            integrator.setStiffModeFriction(gamma);
            Context context(system, integrator, platform(), properties());
            context.setPositions({Vec3(), Vec3()});
            context.setVelocities({Vec3(), driverVelocity});
            integrator.step((int)std::lround(3.0 / H));
            const vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
            const Vec3 exactV = growth / k, dv = v[0] - exactV;
            EXPECT_LT(std::sqrt(dv.dot(dv)), 1e-6 * std::sqrt(exactV.dot(exactV)));
            // Positions: within 1% of a step's change of F/k, behind F/k by the friction lag gamma/omega_f^2 of the
            // force's rate, omega_f the flow's frequency (for a steadily growing force a mode flowing at omega~ with
            // kicks keeping the static response 1/omega^2 sits (omega/omega~)^2 farther behind than the true one).
            const double turn = variant.splitting == StochasticImpulseIntegrator::Filtered ? omega * H
                                : variant.maxWarpedPhase > 0 ? std::min(warpedTurn(omega * H), variant.maxWarpedPhase)
                                                             : warpedTurn(omega * H);
            const double flowOmega = turn / H;
            const Vec3 exactX = (q[1] * coupling - growth * (gamma / (flowOmega * flowOmega))) / k, dx = q[0] - exactX;
            EXPECT_LT(std::sqrt(dx.dot(dx)), 0.01 * H * std::sqrt(exactV.dot(exactV)));
        }
}

TEST_P(ImpulseFiltered, SettingTheStateStartsTheNextStepAfresh) {
    // The velocity processing carries the last step's change of the soft force into the next step.  After
    // setPositions and setVelocities that history is forgotten: the next step is the step a new Context takes from
    // that state.  Without friction, so the random streams play no part.
    const double omega = 300.0;
    System system;
    system.addParticle(2.0);
    CustomExternalForce* tether = new CustomExternalForce("0.5*k*(x^2+y^2+z^2)");
    tether->addGlobalParameter("k", 2.0 * omega * omega);
    tether->addParticle(0);
    tether->setForceGroup(StiffGroup);
    system.addForce(tether);
    CustomExternalForce* soft = new CustomExternalForce("1e4*(x^4+y^4+z^4)-30*x+12*y");
    soft->addParticle(0);
    system.addForce(soft);
    const Vec3 q(0.05, -0.02, 0.03), v(1.0, 2.0, -0.5);
    for (const BiasFreeStep& variant : BiasFreeSteps) {
        SCOPED_TRACE(variant.name());
        StochasticImpulseIntegrator used(0.0, 0.0, 0.005, StiffMask), fresh(0.0, 0.0, 0.005, StiffMask);
        variant.configure(used);
        variant.configure(fresh);
        Context usedContext(system, used, platform(), properties());
        Context freshContext(system, fresh, platform(), properties());
        usedContext.setPositions({Vec3(0.1, 0.0, 0.0)});
        usedContext.setVelocities({Vec3(0.0, 3.0, 0.0)});
        used.step(20);
        usedContext.setPositions({q});
        usedContext.setVelocities({v});
        freshContext.setPositions({q});
        freshContext.setVelocities({v});
        used.step(1);
        fresh.step(1);
        // The new Context measures its stiff modes at q, the used one measured them at its first position: they agree
        // to rounding (with the history kept, the Filtered step differs by 7e-5 nm and 1.4e-3 nm/ps).
        const Vec3 dq = positionsOf(freshContext)[0] - positionsOf(usedContext)[0];
        const Vec3 dv = velocitiesOf(freshContext)[0] - velocitiesOf(usedContext)[0];
        EXPECT_LT(std::sqrt(dq.dot(dq)), 1e-13);
        EXPECT_LT(std::sqrt(dv.dot(dv)), 1e-11);
    }
}

TEST_P(ImpulseFiltered, ASoftForceStiffAlongAModeIsStableExactlyBelowItsThreshold) {
    // A tethered particle (omega = 1000/ps, no friction) whose soft force is itself a spring r k along the stiff mode.
    // The Filtered step's transfer matrix has trace 2 (cos xi - r (1 - cos xi)): stable while tan^2(xi/2) < 1/r; the
    // Warped step's 2 - 4 (1 + r) sin^2(xi~/2): stable while (1 + r) sin^2(xi~/2) < 1, the same condition at xi~
    // (warpedTurn); Strang's 2 cos xi - r xi sin xi: stable while r < 2 (1 + cos xi)/(xi sin xi).  For r = 0.3 the
    // thresholds are found by bisection here (xi = 2.14, 2.79, 2.44); 200 steps 2% below a threshold stay within 20
    // times the start, 2% above they grow past 1000 times it.
    const double omega = 1000.0, mass = 1.0, r = 0.3, k = mass * omega * omega;
    System system;
    system.addParticle(mass);
    CustomExternalForce* tether = new CustomExternalForce("0.5*k*(x^2+y^2+z^2)");
    tether->addGlobalParameter("k", k);
    tether->addParticle(0);
    tether->setForceGroup(StiffGroup);
    system.addForce(tether);
    CustomExternalForce* soft = new CustomExternalForce("0.5*rk*(x^2+y^2+z^2)");
    soft->addGlobalParameter("rk", r * k);
    soft->addParticle(0);
    system.addForce(soft);
    auto threshold = [](auto stable) {
        double lo = 0.1, hi = Pi - 1e-9;
        for (int i = 0; i < 100; ++i)
            (stable(0.5 * (lo + hi)) ? lo : hi) = 0.5 * (lo + hi);
        return lo;
    };
    const double filteredLimit = threshold([&](double xi) { return std::pow(std::tan(0.5 * xi), 2) < 1 / r; });
    const double strangLimit = threshold([&](double xi) { return r < 2 * (1 + std::cos(xi)) / (xi * std::sin(xi)); });
    const double warpedLimit = threshold([&](double xi) {
        const double halfSine = std::sin(0.5 * warpedTurn(xi));
        return (1 + r) * halfSine * halfSine < 1;
    });
    EXPECT_NEAR(2 * std::atan(1 / std::sqrt(r)), filteredLimit, 1e-9);
    // Bounded (within 20 times the start over 200 steps) or growing (past 1000 times it).
    auto expectBoundedOrGrowing = [&](StochasticImpulseIntegrator& integrator, bool bounded) {
        Context context(system, integrator, platform(), properties());
        context.setPositions({Vec3(1e-3, 0, 0)});
        double largest = 0;
        for (int step = 0; step < 200 && largest < 1.0; ++step) {
            integrator.step(1);
            largest = std::max(largest, std::abs(positionsOf(context)[0][0]));
        }
        if (bounded)
            EXPECT_LT(largest, 20 * 1e-3);
        else
            EXPECT_GE(largest, 1.0);
    };
    for (auto splitting : {StochasticImpulseIntegrator::Filtered, StochasticImpulseIntegrator::Warped,
                           StochasticImpulseIntegrator::Strang}) {
        const double limit = splitting == StochasticImpulseIntegrator::Filtered ? filteredLimit
                             : splitting == StochasticImpulseIntegrator::Warped ? warpedLimit
                                                                                : strangLimit;
        for (double factor : {0.98, 1.02}) {
            SCOPED_TRACE(nameOf(splitting) + " at " + std::to_string(factor) +
                         " of omega H = " + std::to_string(limit));
            StochasticImpulseIntegrator integrator(0.0, 0.0, factor * limit / omega, StiffMask);
            integrator.setSplitting(splitting);
            // Warped's own step, without the limit it would choose (below).
            if (splitting == StochasticImpulseIntegrator::Warped)
                integrator.setMaxWarpedPhase(Pi);
            expectBoundedOrGrowing(integrator, factor < 1);
        }
    }
    // The limit Warped chooses by itself (setMaxWarpedPhase(0), the default): r measured 0.3 to 1e-4, the phase
    // 2 asin(1/sqrt(1 + 1.05 r)) below the edge 2.140, and the step held at 1.02, 2 and 4 times Warped's threshold.
    for (double stepFactor : {1.02, 2.0, 4.0}) {
        SCOPED_TRACE("Warped with its chosen limit at omega H = " + std::to_string(stepFactor * warpedLimit));
        StochasticImpulseIntegrator integrator(0.0, 0.0, stepFactor * warpedLimit / omega, StiffMask);
        integrator.setSplitting(StochasticImpulseIntegrator::Warped);
        expectBoundedOrGrowing(integrator, true);
    }
    {
        StochasticImpulseIntegrator integrator(0.0, 0.0, 2 * warpedLimit / omega, StiffMask);
        integrator.setSplitting(StochasticImpulseIntegrator::Warped);
        Context context(system, integrator, platform(), properties());
        context.setPositions({Vec3(1e-3, 0, 0)});
        const std::string text = integrator.describeContext();
        const std::string chosenAt = "Warped phase limit chosen here (setMaxWarpedPhase(0)): ";
        const size_t at = text.find(chosenAt);
        ASSERT_NE(std::string::npos, at) << text;
        const double chosen = std::stod(text.substr(at + chosenAt.size()));
        EXPECT_NEAR(2 * std::asin(1 / std::sqrt(1 + 1.05 * r)), chosen, 1e-3) << text;
        const size_t ratioAt = text.find("up to ");
        EXPECT_NEAR(r, std::stod(text.substr(ratioAt + 6)), 1e-3 * r) << text;
    }
    // Warped with its phase limited to maxPhase: (1 + r) sin^2(min(xi~, maxPhase)/2) < 1, whatever omega H is.  The
    // limiting phase for r = 0.3 is 2 asin(1/sqrt(1.3)) = 2.140: a limit 2% below it holds at 1.02, 2 and 4 times
    // Warped's own threshold in omega H; a limit 2% above grows there.
    const double limitingPhase = 2 * std::asin(1 / std::sqrt(1 + r));
    for (double phaseFactor : {0.98, 1.02})
        for (double stepFactor : {1.02, 2.0, 4.0}) {
            SCOPED_TRACE("Warped limited to " + std::to_string(phaseFactor) + " of " + std::to_string(limitingPhase) +
                         " at omega H = " + std::to_string(stepFactor * warpedLimit));
            StochasticImpulseIntegrator integrator(0.0, 0.0, stepFactor * warpedLimit / omega, StiffMask);
            integrator.setSplitting(StochasticImpulseIntegrator::Warped);
            integrator.setMaxWarpedPhase(phaseFactor * limitingPhase);
            expectBoundedOrGrowing(integrator, phaseFactor < 1);
        }
}

TEST_P(ImpulseFiltered, TheWarpedPhaseLimitIsCheckedDescribedAndSerialized) {
    TetheredParticle p(1036.0);
    StochasticImpulseIntegrator integrator(0.0, 0.0, 0.003, StiffMask);
    EXPECT_EQ(0.0, integrator.getMaxWarpedPhase());
    for (double bad : {-0.5, Pi + 1e-9, 4.0, std::nan("")})
        expectRejected([&] { integrator.setMaxWarpedPhase(bad); }, {"maxWarpedPhase", "between 0 and pi"});
    EXPECT_EQ(0.0, integrator.getMaxWarpedPhase());
    integrator.setMaxWarpedPhase(Pi); // no limit
    EXPECT_EQ(Pi, integrator.getMaxWarpedPhase());
    integrator.setMaxWarpedPhase(2.05);
    EXPECT_EQ(2.05, integrator.getMaxWarpedPhase());
    // Only Warped has a warped frequency to limit: another splitting is rejected when a step is taken, and the
    // Context takes steps once the splitting is Warped.
    Context context(p.system, integrator, platform(), properties());
    context.setPositions({p.equilibrium()});
    expectRejected([&] { integrator.step(1); }, {"maxWarpedPhase = 2.05", "splitting = 1", "Warped (4)"});
    EXPECT_EQ(0, context.getState(State::Positions).getStepCount());
    integrator.setSplitting(StochasticImpulseIntegrator::Warped);
    integrator.step(2);
    EXPECT_EQ(2, context.getState(State::Positions).getStepCount());
    EXPECT_NE(std::string::npos, integrator.describeStep().find("ω̃H ≤ 2.05")) << integrator.describeStep();
    std::stringstream buffer;
    XmlSerializer::serialize<Integrator>(&integrator, "Integrator", buffer);
    std::unique_ptr<Integrator> copy(XmlSerializer::deserialize<Integrator>(buffer));
    EXPECT_EQ(2.05, dynamic_cast<StochasticImpulseIntegrator&>(*copy).getMaxWarpedPhase());
}

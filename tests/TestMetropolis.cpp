// The Metropolis-adjusted FLAVOR and SIM (setMetropolis): exact sampling where the unadjusted step is biased, the
// rejection rate's order in the step, reversibility of every proposal that qualifies (and of none that is rejected),
// the step as an exact reduction to the unadjusted one, checkpoints, serialization and the rejected settings.

#include "ExpectRejected.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomCompoundBondForce.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/State.h"
#include "openmm/System.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include "openmm/serialization/XmlSerializer.h"
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class MetropolisAdjusted : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(MetropolisAdjusted);

namespace {

const double Temperature = 300.0;
const double KT = BOLTZ * Temperature;

/**
 * Pairs of unit-mass particles in a soft harmonic well 0.5 k |r|^2 (group 0), each pair joined by a stiff zero-length
 * spring 0.5 K |r1 - r2|^2 (group 1).  Per coordinate, the pair's centre c and separation d are independent Gaussians:
 * <c^2> = kT / (2 k), <d^2> = kT / (K + k / 2).  With the well on the centres (k |c|^2) the soft force has no
 * component along the stiff separation.
 */
struct SpringPairs {
    SpringPairs(int pairs, double soft, double stiff, bool wellOnCentres = false)
        : numPairs(pairs), soft(soft), stiff(stiff) {
        auto* springs = new HarmonicBondForce();
        springs->setForceGroup(1);
        auto* well = new CustomExternalForce("0.5*k*(x^2+y^2+z^2)");
        well->addGlobalParameter("k", soft);
        auto* centreWell = new CustomCompoundBondForce(2, "0.25*k*((x1+x2)^2+(y1+y2)^2+(z1+z2)^2)");
        centreWell->addGlobalParameter("k", soft);
        for (int i = 0; i < pairs; ++i) {
            system.addParticle(1.0);
            system.addParticle(1.0);
            well->addParticle(2 * i, {});
            well->addParticle(2 * i + 1, {});
            centreWell->addBond({2 * i, 2 * i + 1}, {});
            springs->addBond(2 * i, 2 * i + 1, 0.0, stiff);
        }
        if (wellOnCentres) {
            system.addForce(centreWell);
            delete well;
        } else {
            system.addForce(well);
            delete centreWell;
        }
        system.addForce(springs);
    }
    /** Thermal positions (nonzero separations: a zero-length bond has no direction at r = 0) and velocities. */
    void start(Context& context, unsigned seed) const {
        std::mt19937 random(seed);
        std::normal_distribution<double> normal;
        vector<Vec3> positions, velocities;
        const double cSpread = std::sqrt(KT / (2 * soft)), dSpread = std::sqrt(KT / (stiff + soft / 2));
        for (int i = 0; i < numPairs; ++i) {
            Vec3 c(normal(random), normal(random), normal(random)), d(normal(random), normal(random), normal(random));
            c *= cSpread;
            d *= dSpread;
            positions.push_back(c + d * 0.5);
            positions.push_back(c - d * 0.5);
        }
        for (int i = 0; i < 2 * numPairs; ++i)
            velocities.push_back(Vec3(normal(random), normal(random), normal(random)) * std::sqrt(KT));
        context.setPositions(positions);
        context.setVelocities(velocities);
    }
    double exactCentreSquare() const { return KT / (2 * soft); }
    double exactSeparationSquare() const { return KT / (stiff + soft / 2); }
    System system;
    int numPairs;
    double soft, stiff;
};

/** A mean and its standard error from block means. */
struct Estimate {
    double mean, error;
    double z(double exact) const { return (mean - exact) / error; }
};

Estimate blockEstimate(const vector<double>& samples, int blocks) {
    const size_t perBlock = samples.size() / blocks;
    vector<double> means(blocks, 0.0);
    for (int b = 0; b < blocks; ++b) {
        for (size_t k = 0; k < perBlock; ++k)
            means[b] += samples[b * perBlock + k];
        means[b] /= perBlock;
    }
    const BlockMean estimate = blockMean(means);
    return {estimate.mean, estimate.standardError};
}

/** <c^2> and <d^2> per coordinate over steps after burnIn. */
std::pair<Estimate, Estimate> sample(Context& context, Integrator& integrator, const SpringPairs& model, int burnIn,
                                     int steps) {
    integrator.step(burnIn);
    vector<double> centres, separations;
    for (int s = 0; s < steps; ++s) {
        integrator.step(1);
        const vector<Vec3> q = context.getState(State::Positions).getPositions();
        double c2 = 0.0, d2 = 0.0;
        for (int i = 0; i < model.numPairs; ++i) {
            const Vec3 c = (q[2 * i] + q[2 * i + 1]) * 0.5, d = q[2 * i] - q[2 * i + 1];
            c2 += c.dot(c) / (3 * model.numPairs);
            d2 += d.dot(d) / (3 * model.numPairs);
        }
        centres.push_back(c2);
        separations.push_back(d2);
    }
    return {blockEstimate(centres, 20), blockEstimate(separations, 20)};
}

/** The maximum difference between two lists of vectors. */
double maxDifference(const vector<Vec3>& a, const vector<Vec3>& b) {
    double worst = 0.0;
    for (size_t i = 0; i < a.size(); ++i)
        for (int k = 0; k < 3; ++k)
            worst = std::max(worst, std::abs(a[i][k] - b[i][k]));
    return worst;
}

vector<Vec3> negated(vector<Vec3> v) {
    for (Vec3& x : v)
        x = -x;
    return v;
}

/** A FLAVOR with the Verlet scheme at 300 K. */
std::unique_ptr<FlavorIntegrator> verletFlavor(double delta, double tau, FlavorIntegrator::Averaging averaging,
                                               double friction) {
    auto integrator = std::make_unique<FlavorIntegrator>(delta, tau, 1 << 1);
    integrator->setScheme(FlavorIntegrator::Verlet);
    integrator->setAveraging(averaging);
    integrator->setTemperature(Temperature);
    integrator->setFriction(friction);
    integrator->setRandomNumberSeed(11);
    return integrator;
}

std::unique_ptr<StochasticImpulseIntegrator> impulse(double H, StochasticImpulseIntegrator::Splitting splitting,
                                                     double friction) {
    auto integrator = std::make_unique<StochasticImpulseIntegrator>(Temperature, friction, H, 1 << 1);
    integrator->setSplitting(splitting);
    integrator->setRandomNumberSeed(11);
    return integrator;
}

/**
 * Samples the model with the integrator make(adjusted) unadjusted and adjusted: the unadjusted centres are off by more
 * than 10 standard errors, the adjusted centres and separations within 4 of the exact values.
 */
void expectAdjustedExactWhereUnadjustedIsBiased(const SpringPairs& model, Platform& platform,
                                                const std::map<std::string, std::string>& properties,
                                                const std::function<std::unique_ptr<Integrator>(bool)>& make,
                                                const std::function<double(Integrator&)>& acceptance) {
    for (bool adjusted : {false, true}) {
        std::unique_ptr<Integrator> integrator = make(adjusted);
        Context context(model.system, *integrator, platform, properties);
        model.start(context, 5);
        const auto [centre, separation] = sample(context, *integrator, model, 200, 6000);
        if (adjusted) {
            EXPECT_LT(std::abs(centre.z(model.exactCentreSquare())), 4.0) << centre.mean;
            EXPECT_LT(std::abs(separation.z(model.exactSeparationSquare())), 4.0) << separation.mean;
            EXPECT_GT(acceptance(*integrator), 0.3);
        } else {
            EXPECT_GT(centre.z(model.exactCentreSquare()), 10.0) << centre.mean;
        }
    }
}

} // namespace

// The soft well at omega H = 1: the unadjusted Strang SIM (O inside its exact flow) widens the centres by 11 %, more
// than 10 standard errors; adjusted, both spreads agree with the exact values within 4 standard errors.
TEST_P(MetropolisAdjusted, StrangImpulseSamplesExactlyWhereUnadjustedIsBiased) {
    expectAdjustedExactWhereUnadjustedIsBiased(
        SpringPairs(10, 100.0, 1e5), platform(), properties(1),
        [](bool adjusted) {
            auto integrator = impulse(0.1, StochasticImpulseIntegrator::Strang, 5.0);
            integrator->setMetropolis(adjusted);
            return std::unique_ptr<Integrator>(std::move(integrator));
        },
        [](Integrator& i) { return static_cast<StochasticImpulseIntegrator&>(i).getAcceptanceRate(); });
}

// The artificial FLAVOR at omega_soft delta = 1 over a stiff spring with omega tau = 0.7: unadjusted, the centres are
// off by 30 %; adjusted, both spreads are exact within 4 standard errors.
TEST_P(MetropolisAdjusted, ArtificialFlavorSamplesExactlyWhereUnadjustedIsBiased) {
    expectAdjustedExactWhereUnadjustedIsBiased(
        SpringPairs(10, 1e4, 1e6), platform(), properties(1),
        [](bool adjusted) {
            auto integrator = verletFlavor(0.01, 0.0005, FlavorIntegrator::ArtificialProjected, 50.0);
            integrator->setMetropolis(adjusted);
            return std::unique_ptr<Integrator>(std::move(integrator));
        },
        [](Integrator& i) { return static_cast<FlavorIntegrator&>(i).getAcceptanceRate(); });
}

// Rejections are E[max(0, dH)] / kT ~ the spread of dH, the local energy error: H^3 for Strang (second order), H^5
// for Yoshida4 (fourth order).  The soft well acts on the pairs' centres: a soft force along a stiff mode with
// omega H >> 1 adds an error that is not yet in this asymptotic regime (the slope then measures below 2).
TEST_P(MetropolisAdjusted, RejectionFallsAtTheSplittingsOrder) {
    SpringPairs model(10, 100.0, 1e5, true);
    struct Case {
        StochasticImpulseIntegrator::Splitting splitting;
        double stepSize, order;
        int rounds;
    };
    for (const Case& c : {Case{StochasticImpulseIntegrator::Strang, 0.08, 2, 160},
                          Case{StochasticImpulseIntegrator::Yoshida4, 0.08, 4, 480}}) {
        vector<double> rejected;
        for (double H : {c.stepSize, c.stepSize / 2}) {
            // Friction only where the splitting allows it; every 50 steps fresh thermal velocities for Yoshida4.
            const bool friction = c.splitting == StochasticImpulseIntegrator::Strang;
            auto integrator = impulse(H, c.splitting, friction ? 10.0 : 0.0);
            integrator->setMetropolis(true);
            Context context(model.system, *integrator, platform(), properties(1));
            model.start(context, 7);
            for (int round = 0; round < c.rounds; ++round) {
                if (!friction)
                    context.setVelocitiesToTemperature(Temperature, 100 + round);
                integrator->step(50);
            }
            rejected.push_back((1.0 - integrator->getAcceptanceRate()) * 50 * c.rounds);
        }
        // The counts are about Poisson: the slope's standard error follows from them.
        const double slope = std::log2(rejected[0] / rejected[1]);
        const double error = std::sqrt(1 / rejected[0] + 1 / rejected[1]) / std::log(2.0);
        EXPECT_NEAR(c.order + 1, slope, 4 * error)
            << rejected[0] << " rejections at H, " << rejected[1] << " at H/2, splitting " << c.splitting;
        EXPECT_LT(4 * error, 1.0);
    }
}

// Every proposal that qualifies is reversible: from (q1, -v1) it returns to (q0, -v0), to rounding.  The rejected
// SymplecticEuler, LieTrotter and Warped steps are not: their reversed step misses the start by far more.
TEST_P(MetropolisAdjusted, QualifyingProposalsAreReversibleAndRejectedOnesAreNot) {
    SpringPairs model(4, 1e4, 1e6);
    struct Case {
        std::string name;
        std::function<std::unique_ptr<Integrator>()> make;
        bool reversible;
    };
    auto flavor = [](FlavorIntegrator::Averaging averaging, bool exact, FlavorIntegrator::Scheme scheme) {
        return [=] {
            auto integrator = verletFlavor(0.01, 0.0005, averaging, 0.0);
            integrator->setExactFastFlow(exact);
            integrator->setScheme(scheme);
            return std::unique_ptr<Integrator>(std::move(integrator));
        };
    };
    auto sim = [](StochasticImpulseIntegrator::Splitting splitting) {
        return [=] { return std::unique_ptr<Integrator>(impulse(0.004, splitting, 0.0)); };
    };
    const vector<Case> cases = {
        {"FLAVOR Nonintrusive", flavor(FlavorIntegrator::Nonintrusive, false, FlavorIntegrator::Verlet), true},
        {"FLAVOR Artificial", flavor(FlavorIntegrator::Artificial, false, FlavorIntegrator::Verlet), true},
        {"FLAVOR Artificial exact", flavor(FlavorIntegrator::Artificial, true, FlavorIntegrator::Verlet), true},
        {"FLAVOR ArtificialProjected", flavor(FlavorIntegrator::ArtificialProjected, false, FlavorIntegrator::Verlet),
         true},
        {"FLAVOR ArtificialProjected exact",
         flavor(FlavorIntegrator::ArtificialProjected, true, FlavorIntegrator::Verlet), true},
        {"SIM Strang", sim(StochasticImpulseIntegrator::Strang), true},
        {"SIM Yoshida4", sim(StochasticImpulseIntegrator::Yoshida4), true},
        {"SIM Filtered", sim(StochasticImpulseIntegrator::Filtered), true},
        {"SIM Warped", sim(StochasticImpulseIntegrator::Warped), false},
        {"FLAVOR SymplecticEuler", flavor(FlavorIntegrator::Nonintrusive, false, FlavorIntegrator::SymplecticEuler),
         false},
        {"SIM LieTrotter", sim(StochasticImpulseIntegrator::LieTrotter), false},
    };
    for (const Case& c : cases) {
        std::unique_ptr<Integrator> integrator = c.make();
        Context context(model.system, *integrator, platform(), properties(1));
        model.start(context, 3);
        const State start = context.getState(State::Positions | State::Velocities);
        integrator->step(1);
        const State proposed = context.getState(State::Positions | State::Velocities);
        context.setVelocities(negated(proposed.getVelocities()));
        integrator->step(1);
        const State back = context.getState(State::Positions | State::Velocities);
        const double positionMiss = maxDifference(back.getPositions(), start.getPositions());
        const double velocityMiss = maxDifference(negated(back.getVelocities()), start.getVelocities());
        // Positions are ~0.01 nm and velocities ~1.6 nm/ps.
        if (c.reversible) {
            EXPECT_LT(positionMiss, 1e-12) << c.name;
            EXPECT_LT(velocityMiss, 1e-10) << c.name;
        } else {
            EXPECT_GT(std::max(positionMiss / 1e-12, velocityMiss / 1e-10), 1e3) << c.name;
        }
    }
}

// Without friction an adjusted step ends where the unadjusted step ends (accepted) or where it started with reversed
// velocities (rejected), accepted for dH <= 0, and the acceptance rate counts exactly these outcomes.
TEST_P(MetropolisAdjusted, WithoutFrictionEachStepIsTheUnadjustedStepOrItsReversal) {
    SpringPairs model(10, 100.0, 1e5);
    auto adjusted = impulse(0.1, StochasticImpulseIntegrator::Strang, 0.0);
    auto plain = impulse(0.1, StochasticImpulseIntegrator::Strang, 0.0);
    adjusted->setMetropolis(true);
    Context adjustedContext(model.system, *adjusted, platform(), properties(1));
    Context plainContext(model.system, *plain, platform(), properties(1));
    model.start(adjustedContext, 9);
    int accepted = 0, rejected = 0;
    const int steps = 200;
    for (int s = 0; s < steps; ++s) {
        const State before = adjustedContext.getState(State::Positions | State::Velocities | State::Energy);
        plainContext.setPositions(before.getPositions());
        plainContext.setVelocities(before.getVelocities());
        plain->step(1);
        const State unadjusted = plainContext.getState(State::Positions | State::Velocities | State::Energy);
        adjusted->step(1);
        const State after = adjustedContext.getState(State::Positions | State::Velocities);
        const double change = unadjusted.getPotentialEnergy() + unadjusted.getKineticEnergy() -
                              before.getPotentialEnergy() - before.getKineticEnergy();
        const bool wasAccepted = maxDifference(after.getPositions(), unadjusted.getPositions()) < 1e-12 &&
                                 maxDifference(after.getVelocities(), unadjusted.getVelocities()) < 1e-10;
        const bool wasRejected = maxDifference(after.getPositions(), before.getPositions()) == 0.0 &&
                                 maxDifference(after.getVelocities(), negated(before.getVelocities())) == 0.0;
        ASSERT_TRUE(wasAccepted != wasRejected) << "step " << s;
        if (change < -1e-9 * KT) {
            EXPECT_TRUE(wasAccepted) << "step " << s << ": dH = " << change;
        }
        if (change > 20 * KT) {
            EXPECT_TRUE(wasRejected) << "step " << s << ": dH = " << change;
        }
        (wasAccepted ? accepted : rejected)++;
    }
    EXPECT_GT(accepted, 0);
    EXPECT_GT(rejected, 0);
    EXPECT_DOUBLE_EQ((double)accepted / steps, adjusted->getAcceptanceRate());
}

// A checkpoint carries the random streams and the proposal counts: the continuation is the same bit for bit.
TEST_P(MetropolisAdjusted, CheckpointContinuesBitForBit) {
    SpringPairs model(10, 100.0, 1e5);
    auto integrator = impulse(0.1, StochasticImpulseIntegrator::Strang, 5.0);
    integrator->setMetropolis(true);
    Context context(model.system, *integrator, platform(), properties(1));
    model.start(context, 2);
    integrator->step(30);
    std::stringstream checkpoint;
    context.createCheckpoint(checkpoint);
    const double rateAtCheckpoint = integrator->getAcceptanceRate();
    integrator->step(40);
    const State first = context.getState(State::Positions | State::Velocities);
    const double firstRate = integrator->getAcceptanceRate();
    EXPECT_NE(rateAtCheckpoint, firstRate);
    context.loadCheckpoint(checkpoint);
    EXPECT_EQ(rateAtCheckpoint, integrator->getAcceptanceRate());
    integrator->step(40);
    const State second = context.getState(State::Positions | State::Velocities);
    EXPECT_EQ(0.0, maxDifference(first.getPositions(), second.getPositions()));
    EXPECT_EQ(0.0, maxDifference(first.getVelocities(), second.getVelocities()));
    EXPECT_EQ(firstRate, integrator->getAcceptanceRate());
}

TEST_P(MetropolisAdjusted, SerializationKeepsTheSetting) {
    for (int which = 0; which < 2; ++which) {
        std::unique_ptr<Integrator> integrator;
        if (which == 0)
            integrator = verletFlavor(0.01, 0.001, FlavorIntegrator::Nonintrusive, 1.0);
        else
            integrator = impulse(0.01, StochasticImpulseIntegrator::Strang, 1.0);
        for (bool on : {false, true}) {
            if (which == 0)
                static_cast<FlavorIntegrator&>(*integrator).setMetropolis(on);
            else
                static_cast<StochasticImpulseIntegrator&>(*integrator).setMetropolis(on);
            std::stringstream buffer;
            XmlSerializer::serialize<Integrator>(integrator.get(), "Integrator", buffer);
            std::unique_ptr<Integrator> copy(XmlSerializer::deserialize<Integrator>(buffer));
            const bool copied = which == 0 ? dynamic_cast<FlavorIntegrator&>(*copy).getMetropolis()
                                           : dynamic_cast<StochasticImpulseIntegrator&>(*copy).getMetropolis();
            EXPECT_EQ(on, copied);
        }
    }
}

// Each setting whose proposal is not reversible and volume-preserving, or whose target is not one Boltzmann
// distribution, is rejected when a step starts; the Context keeps its state and steps once the setting is undone.
TEST_P(MetropolisAdjusted, SettingsWithoutAnExactProposalAreRejectedAndTheContextStaysUsable) {
    SpringPairs model(2, 100.0, 1e5);
    struct Case {
        std::string fragment;
        std::function<void(FlavorIntegrator*, StochasticImpulseIntegrator*)> set, undo;
    };
    const vector<Case> cases = {
        {"scheme = SymplecticEuler",
         [](FlavorIntegrator* f, StochasticImpulseIntegrator*) { f->setScheme(FlavorIntegrator::SymplecticEuler); },
         [](FlavorIntegrator* f, StochasticImpulseIntegrator*) { f->setScheme(FlavorIntegrator::Verlet); }},
        {"stiffFriction = true", [](FlavorIntegrator* f, StochasticImpulseIntegrator*) { f->setStiffFriction(true); },
         [](FlavorIntegrator* f, StochasticImpulseIntegrator*) { f->setStiffFriction(false); }},
        {"temperature = 0 K", [](FlavorIntegrator* f, StochasticImpulseIntegrator*) { f->setTemperature(0.0); },
         [](FlavorIntegrator* f, StochasticImpulseIntegrator*) { f->setTemperature(Temperature); }},
        {"splitting = LieTrotter",
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) {
             s->setSplitting(StochasticImpulseIntegrator::LieTrotter);
         },
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) {
             s->setSplitting(StochasticImpulseIntegrator::Strang);
         }},
        {"splitting = Warped",
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) {
             s->setSplitting(StochasticImpulseIntegrator::Warped);
         },
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) {
             s->setSplitting(StochasticImpulseIntegrator::Strang);
         }},
        {"stiff-mode temperature",
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) { s->setStiffModeTemperature(1.0); },
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) { s->setStiffModeTemperature(Temperature); }},
        {"stiffModeFriction = 20",
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) { s->setStiffModeFriction(20.0); },
         [](FlavorIntegrator*, StochasticImpulseIntegrator* s) { s->setStiffModeFriction(5.0); }},
    };
    for (const Case& c : cases) {
        const bool isFlavor = c.fragment.find("Euler") != std::string::npos ||
                              c.fragment.find("stiffFriction") != std::string::npos ||
                              c.fragment.find("temperature = 0") != std::string::npos;
        std::unique_ptr<FlavorIntegrator> flavor;
        std::unique_ptr<StochasticImpulseIntegrator> sim;
        Integrator* integrator;
        if (isFlavor) {
            flavor = verletFlavor(0.002, 0.0005, FlavorIntegrator::Nonintrusive, 5.0);
            flavor->setMetropolis(true);
            integrator = flavor.get();
        } else {
            sim = impulse(0.01, StochasticImpulseIntegrator::Strang, 5.0);
            sim->setMetropolis(true);
            integrator = sim.get();
        }
        Context context(model.system, *integrator, platform(), properties(1));
        model.start(context, 1);
        const vector<Vec3> start = context.getState(State::Positions).getPositions();
        c.set(flavor.get(), sim.get());
        expectRejected([&] { integrator->step(1); }, {"Metropolis", c.fragment, "setMetropolis(false)"});
        EXPECT_EQ(0.0, maxDifference(start, context.getState(State::Positions).getPositions())) << c.fragment;
        EXPECT_TRUE(std::isnan(isFlavor ? flavor->getAcceptanceRate() : sim->getAcceptanceRate())) << c.fragment;
        c.undo(flavor.get(), sim.get());
        integrator->step(5);
        EXPECT_GT(isFlavor ? flavor->getAcceptanceRate() : sim->getAcceptanceRate(), 0.0) << c.fragment;
    }
}

TEST_P(MetropolisAdjusted, ConstraintsAreRejected) {
    SpringPairs model(2, 100.0, 1e5);
    model.system.addParticle(1.0);
    model.system.addParticle(1.0);
    model.system.addConstraint(4, 5, 0.1);
    auto integrator = impulse(0.01, StochasticImpulseIntegrator::Strang, 5.0);
    integrator->setMetropolis(true);
    Context context(model.system, *integrator, platform(), properties(1));
    vector<Vec3> positions = {Vec3(0, 0, 0),    Vec3(0.01, 0, 0), Vec3(1, 0, 0),
                              Vec3(1.01, 0, 0), Vec3(2, 0, 0),    Vec3(2.1, 0, 0)};
    context.setPositions(positions);
    expectRejected([&] { integrator->step(1); }, {"Metropolis", "constraints", "constraint tolerance"});
    integrator->setMetropolis(false);
    integrator->step(2);
}

TEST(MetropolisAdjustedApi, AcceptanceRateNeedsAContext) {
    FlavorIntegrator flavor(0.002, 0.001, 2);
    EXPECT_FALSE(flavor.getMetropolis());
    expectRejected([&] { flavor.getAcceptanceRate(); }, {"getAcceptanceRate", "not bound to a Context"});
    StochasticImpulseIntegrator sim(300, 1, 0.002, 2);
    EXPECT_FALSE(sim.getMetropolis());
    expectRejected([&] { sim.getAcceptanceRate(); }, {"getAcceptanceRate", "not bound to a Context"});
}

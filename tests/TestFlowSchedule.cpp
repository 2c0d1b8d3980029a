#include "internal/FlowSchedule.h"
#include "internal/PhysicalConstants.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <gtest/gtest.h>
#include <utility>
#include <vector>

using namespace FlavorPlugin;

namespace {

const int Stiff = 1 << 1;
const int Soft = ~Stiff;

FlavorParameters parameters(FlavorIntegrator::Scheme scheme, double delta, double tau, double friction = 0.0,
                            bool stiffFriction = false) {
    return FlavorParameters{
        scheme,        FlavorIntegrator::Nonintrusive, false, delta, tau, Stiff, AllForceGroups, friction,
        stiffFriction, FlavorIntegrator::Edges};
}

SubFlow kick(double h, int groups) {
    return SubFlow{SubFlow::Kick, h, groups};
}
SubFlow drift(double h) {
    return SubFlow{SubFlow::Drift, h, 0};
}
// The Langevin schedules below all have friction 1/ps at kT = 0.
SubFlow thermostat(double h) {
    SubFlow flow{SubFlow::Thermostat, h, 0};
    flow.bath.friction = 1.0;
    return flow;
}
SubFlow frozenDrift(double h) {
    SubFlow flow{SubFlow::FrozenDrift, h, 0};
    flow.frozen = SubFlow::FrozenSet::StiffModes;
    return flow;
}
SubFlow frozenKick(double h, int groups) {
    SubFlow flow{SubFlow::FrozenKick, h, groups};
    flow.frozen = SubFlow::FrozenSet::StiffModes;
    return flow;
}
SubFlow filteredStep(SubFlow::Kind kind, double h, int groups) {
    SubFlow flow{kind, h, groups};
    flow.response = SubFlow::KickResponse::Scaled;
    return flow;
}
SubFlow harmonicFlow(double h) {
    return SubFlow{SubFlow::HarmonicFlow, h, 0};
}

FlavorParameters artificial(FlavorIntegrator::Scheme scheme, double delta, double tau, bool projected = false,
                            bool exact = false, double friction = 0.0, bool stiffFriction = false) {
    FlavorParameters p = parameters(scheme, delta, tau, friction, stiffFriction);
    p.averaging = projected ? FlavorIntegrator::ArtificialProjected : FlavorIntegrator::Artificial;
    p.exactFastFlow = exact;
    return p;
}

double totalTime(const Schedule& s, SubFlow::Kind kind, int requiredGroups = 0) {
    double t = 0;
    for (const SubFlow& f : s)
        if (f.kind == kind && (f.groups & requiredGroups) == requiredGroups)
            t += f.h;
    return t;
}

} // namespace

TEST(FlowSchedule, SymplecticEulerIsEquation2_17) {
    Schedule s = flavorSchedule(parameters(FlavorIntegrator::SymplecticEuler, 0.01, 0.001));
    Schedule expected = {kick(0.001, AllForceGroups), drift(0.001), kick(0.01 - 0.001, Soft), drift(0.01 - 0.001)};
    EXPECT_EQ(expected, s);
}

TEST(FlowSchedule, VerletIsEquation2_7) {
    const double delta = 0.01, tau = 0.001, rest = delta - tau;
    Schedule s = flavorSchedule(parameters(FlavorIntegrator::Verlet, delta, tau));
    Schedule expected = {kick(tau / 2, AllForceGroups), drift(tau / 2), kick(rest / 2, Soft),         drift(rest),
                         kick(rest / 2, Soft),          drift(tau / 2), kick(tau / 2, AllForceGroups)};
    EXPECT_EQ(expected, s);
}

TEST(FlowSchedule, StiffForcesActForTheMicrostepAndTimeAdvancesByTheMesostep) {
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet}) {
        Schedule s = flavorSchedule(parameters(scheme, 0.02, 0.003));
        EXPECT_NEAR(0.003, totalTime(s, SubFlow::Kick, Stiff), 1e-17);
        EXPECT_NEAR(0.02, totalTime(s, SubFlow::Kick, 1), 1e-17); // group 0 is soft: always on
        EXPECT_NEAR(0.02, totalTime(s, SubFlow::Drift), 1e-17);
    }
}

TEST(FlowSchedule, EqualStepsReduceToTheLegacyIntegrators) {
    Schedule euler = flavorSchedule(parameters(FlavorIntegrator::SymplecticEuler, 0.01, 0.01));
    EXPECT_EQ((Schedule{kick(0.01, AllForceGroups), drift(0.01)}), euler);
    Schedule verlet = flavorSchedule(parameters(FlavorIntegrator::Verlet, 0.01, 0.01));
    EXPECT_EQ((Schedule{kick(0.005, AllForceGroups), drift(0.01), kick(0.005, AllForceGroups)}), verlet);
}

TEST(FlowSchedule, LangevinPlacesTheThermostatsOfEquations4_7To4_10) {
    const double delta = 0.01, tau = 0.002;
    Schedule slowEuler = flavorSchedule(parameters(FlavorIntegrator::SymplecticEuler, delta, tau, 1.0, false));
    EXPECT_EQ((Schedule{thermostat(tau), kick(tau, AllForceGroups), drift(tau), thermostat(delta - tau),
                        kick(delta - tau, Soft), drift(delta - tau)}),
              slowEuler);
    Schedule stiffEuler = flavorSchedule(parameters(FlavorIntegrator::SymplecticEuler, delta, tau, 1.0, true));
    EXPECT_EQ(
        (Schedule{thermostat(tau), kick(tau, AllForceGroups), drift(tau), kick(delta - tau, Soft), drift(delta - tau)}),
        stiffEuler);
    for (bool stiff : {false, true}) {
        Schedule verlet = flavorSchedule(parameters(FlavorIntegrator::Verlet, delta, tau, 1.0, stiff));
        double edge = stiff ? tau / 2 : delta / 2;
        EXPECT_EQ(thermostat(edge), verlet.front());
        EXPECT_EQ(thermostat(edge), verlet.back());
        EXPECT_NEAR(stiff ? tau : delta, totalTime(verlet, SubFlow::Thermostat), 1e-17);
    }
}

TEST(FlowSchedule, SimplifyDropsEmptyFlowsAndMergesExactCompositions) {
    Schedule s = {drift(0.1), drift(0.2), kick(0.0, 1), kick(0.3, 0), kick(0.1, 1), kick(0.2, 1), kick(0.1, 2)};
    EXPECT_EQ((Schedule{drift(0.1 + 0.2), kick(0.1 + 0.2, 1), kick(0.1, 2)}), simplifySchedule(s));
}

TEST(FlowSchedule, PassesBreakWhereKicksNeedNewPositions) {
    StepPlan plan = analyzeStep(flavorSchedule(parameters(FlavorIntegrator::Verlet, 0.01, 0.001)), false);
    // K_A D | K_S D | K_S D | K_A: three force evaluations per step once the last one is reused.
    ASSERT_EQ(4u, plan.passes.size());
    EXPECT_EQ(2u, plan.passes[0].flows.size());
    EXPECT_EQ(1u, plan.passes[3].flows.size());
    EXPECT_EQ((std::vector<int>{AllForceGroups, Soft}), plan.slotGroups);
    StepPlan constrained = analyzeStep(flavorSchedule(parameters(FlavorIntegrator::Verlet, 0.01, 0.001)), true);
    EXPECT_EQ(7u, constrained.passes.size());
    // With constraints a thermostat and the kick beside it share a pass (one velocity projection): O K_A | D | K_S |
    // D | K_S | D | K_A O.
    StepPlan langevin = analyzeStep(flavorSchedule(parameters(FlavorIntegrator::Verlet, 0.01, 0.001, 1.0)), true);
    ASSERT_EQ(7u, langevin.passes.size());
    EXPECT_EQ((std::vector<SubFlow>{thermostat(0.005), kick(0.0005, AllForceGroups)}), langevin.passes[0].flows);
    EXPECT_EQ((std::vector<SubFlow>{kick(0.0005, AllForceGroups), thermostat(0.005)}), langevin.passes[6].flows);
    for (size_t p = 1; p < 6; ++p)
        EXPECT_EQ(1u, langevin.passes[p].flows.size());
    // The projected artificial FLAVOR: O K_S | FK | FD | K_f | D | K_f | FD | FK | K_S O.
    StepPlan projected =
        analyzeStep(flavorSchedule(artificial(FlavorIntegrator::Verlet, 0.01, 0.001, true, false, 1.0)), true);
    ASSERT_EQ(9u, projected.passes.size());
    EXPECT_EQ(2u, projected.passes[0].flows.size());
    EXPECT_EQ(2u, projected.passes[8].flows.size());
}

TEST(FlowSchedule, FilteredIsTheFilteredStiffFlowAndItsClosingKickWithOneForceSlot) {
    const ImpulseParameters filtered{StochasticImpulseIntegrator::Filtered, 0.002, Stiff, AllForceGroups};
    const Schedule s = impulseSchedule(filtered);
    EXPECT_EQ((Schedule{filteredStep(SubFlow::FilteredStiffFlow, 0.002, Soft),
                        filteredStep(SubFlow::FilteredKick, 0.002, Soft)}),
              s);
    // Both read the soft forces, each in a pass of its own: one force evaluation per step.
    StepPlan plan = analyzeStep(s, false);
    ASSERT_EQ(2u, plan.passes.size());
    EXPECT_EQ((std::vector<int>{Soft}), plan.slotGroups);
    EXPECT_EQ(0, plan.passes[0].slots[0]);
    EXPECT_EQ(0, plan.passes[1].slots[0]);
    // Without soft groups only the exact stiff flow remains.
    const ImpulseParameters stiffOnly{StochasticImpulseIntegrator::Filtered, 0.002, Stiff, Stiff};
    EXPECT_EQ((Schedule{SubFlow{SubFlow::StiffFlow, 0.002, 0}}), impulseSchedule(stiffOnly));
}

TEST(FlowSchedule, ArtificialSymplecticEulerIsEquation2_11) {
    // Theta = theta^tr(delta-tau) o theta^eps(tau) o theta^V(delta), applied right to left; theta^eps is (2.13).
    const double delta = 0.01, tau = 0.001;
    Schedule s = flavorSchedule(artificial(FlavorIntegrator::SymplecticEuler, delta, tau));
    EXPECT_EQ((Schedule{kick(delta, Soft), drift(tau), kick(tau, Stiff), frozenDrift(delta - tau)}), s);
    Schedule exact = flavorSchedule(artificial(FlavorIntegrator::SymplecticEuler, delta, tau, false, true));
    EXPECT_EQ((Schedule{kick(delta, Soft), harmonicFlow(tau), frozenDrift(delta - tau)}), exact);
    Schedule projected = flavorSchedule(artificial(FlavorIntegrator::SymplecticEuler, delta, tau, true));
    EXPECT_EQ((Schedule{kick(delta * (tau / delta), Soft), frozenKick(delta - delta * (tau / delta), Soft), drift(tau),
                        kick(tau, Stiff), frozenDrift(delta - tau)}),
              projected);
}

TEST(FlowSchedule, ArtificialVerletIsTheSymmetricComposition) {
    const double delta = 0.01, tau = 0.001, half = (delta - tau) / 2;
    Schedule s = flavorSchedule(artificial(FlavorIntegrator::Verlet, delta, tau));
    EXPECT_EQ((Schedule{kick(delta / 2, Soft), frozenDrift(half), kick(tau / 2, Stiff), drift(tau),
                        kick(tau / 2, Stiff), frozenDrift(half), kick(delta / 2, Soft)}),
              s);
    Schedule exact = flavorSchedule(artificial(FlavorIntegrator::Verlet, delta, tau, false, true));
    EXPECT_EQ((Schedule{kick(delta / 2, Soft), frozenDrift(half), harmonicFlow(tau), frozenDrift(half),
                        kick(delta / 2, Soft)}),
              exact);
    // Projected: the soft kicks' components along the frozen coordinates last tau/2 instead of delta/2.
    Schedule projected = flavorSchedule(artificial(FlavorIntegrator::Verlet, delta, tau, true));
    for (const Schedule& schedule : {s, projected}) {
        EXPECT_DOUBLE_EQ(delta, totalTime(schedule, SubFlow::Kick, Soft) + totalTime(schedule, SubFlow::FrozenKick));
        EXPECT_DOUBLE_EQ(tau, totalTime(schedule, SubFlow::Kick, Stiff));
        EXPECT_DOUBLE_EQ(tau, totalTime(schedule, SubFlow::Drift));
        EXPECT_DOUBLE_EQ(delta - tau, totalTime(schedule, SubFlow::FrozenDrift));
    }
    EXPECT_DOUBLE_EQ(tau, totalTime(projected, SubFlow::Kick, Soft));
    // The plain part of each soft kick on the outside, next to the thermostat of a Langevin step (one projection).
    const double plainPart = delta / 2 * (tau / delta), frozenPart = delta / 2 - plainPart;
    EXPECT_EQ((Schedule{kick(plainPart, Soft), frozenKick(frozenPart, Soft), frozenDrift(half), kick(tau / 2, Stiff),
                        drift(tau), kick(tau / 2, Stiff), frozenDrift(half), frozenKick(frozenPart, Soft),
                        kick(plainPart, Soft)}),
              projected);
}

TEST(FlowSchedule, ArtificialVerletWithEqualStepsIsTheNonintrusiveSchedule) {
    // No frozen drift is left and the soft and stiff kicks over delta/2 merge: velocity Verlet either way.
    for (bool projected : {false, true})
        EXPECT_EQ(flavorSchedule(parameters(FlavorIntegrator::Verlet, 0.01, 0.01)),
                  flavorSchedule(artificial(FlavorIntegrator::Verlet, 0.01, 0.01, projected)));
    EXPECT_EQ((Schedule{kick(0.01, Soft), drift(0.01), kick(0.01, Stiff)}),
              flavorSchedule(artificial(FlavorIntegrator::SymplecticEuler, 0.01, 0.01)));
}

TEST(FlowSchedule, ArtificialLangevinPlacesTheThermostatsAsTheNonintrusiveSchemes) {
    const double delta = 0.01, tau = 0.002;
    EXPECT_EQ((Schedule{thermostat(tau), kick(delta, Soft), drift(tau), kick(tau, Stiff), thermostat(delta - tau),
                        frozenDrift(delta - tau)}),
              flavorSchedule(artificial(FlavorIntegrator::SymplecticEuler, delta, tau, false, false, 1.0, false)));
    EXPECT_EQ((Schedule{thermostat(tau), kick(delta, Soft), drift(tau), kick(tau, Stiff), frozenDrift(delta - tau)}),
              flavorSchedule(artificial(FlavorIntegrator::SymplecticEuler, delta, tau, false, false, 1.0, true)));
    for (bool stiff : {false, true}) {
        Schedule s = flavorSchedule(artificial(FlavorIntegrator::Verlet, delta, tau, false, true, 1.0, stiff));
        const double edge = stiff ? tau / 2 : delta / 2;
        EXPECT_EQ(thermostat(edge), s.front());
        EXPECT_EQ(thermostat(edge), s.back());
        EXPECT_DOUBLE_EQ(2 * edge, totalTime(s, SubFlow::Thermostat));
    }
}

TEST(FlowSchedule, MiddlePlacementKicksFirstAndThermostatsInTheMiddleOfBothDrifts) {
    const double delta = 0.01, tau = 0.002, half = (delta - tau) / 2;
    for (bool stiff : {false, true}) {
        FlavorParameters p = artificial(FlavorIntegrator::Verlet, delta, tau, false, false, 1.0, stiff);
        p.thermostatPlacement = FlavorIntegrator::Middle;
        EXPECT_EQ((Schedule{kick(delta, Soft), frozenDrift(half), kick(tau, Stiff), drift(tau / 2),
                            thermostat(stiff ? tau : delta), drift(tau / 2), frozenDrift(half)}),
                  flavorSchedule(p));
        // Without friction there is nothing to place: the Edges schedule.
        p.friction = 0.0;
        FlavorParameters edges = p;
        edges.thermostatPlacement = FlavorIntegrator::Edges;
        EXPECT_EQ(flavorSchedule(edges), flavorSchedule(p));
    }
    // Projected: one soft kick over delta, its frozen component weighted by tau/delta; one soft and one stiff
    // evaluation per step.
    FlavorParameters p = artificial(FlavorIntegrator::Verlet, delta, tau, true, false, 1.0);
    p.thermostatPlacement = FlavorIntegrator::Middle;
    const Schedule projected = flavorSchedule(p);
    EXPECT_EQ((Schedule{kick(tau, Soft), frozenKick(delta - tau, Soft), frozenDrift(half), kick(tau, Stiff),
                        drift(tau / 2), thermostat(delta), drift(tau / 2), frozenDrift(half)}),
              projected);
    EXPECT_EQ((std::vector<int>{Soft, Stiff}), analyzeStep(projected, false).slotGroups);
    // With tau = delta: the kicks merge into one kick with every force, then D O D (LangevinMiddleIntegrator).
    p = artificial(FlavorIntegrator::Verlet, delta, delta, true, false, 1.0);
    p.thermostatPlacement = FlavorIntegrator::Middle;
    Schedule reduced = flavorSchedule(p);
    EXPECT_DOUBLE_EQ(delta, totalTime(reduced, SubFlow::Kick, Soft));
    EXPECT_DOUBLE_EQ(delta, totalTime(reduced, SubFlow::Kick, Stiff));
    EXPECT_EQ((Schedule{drift(delta / 2), thermostat(delta), drift(delta / 2)}),
              Schedule(reduced.end() - 3, reduced.end()));
}

TEST(FlowSchedule, FrozenFlowsArePassesOfTheirOwn) {
    StepPlan plan = analyzeStep(flavorSchedule(artificial(FlavorIntegrator::Verlet, 0.01, 0.001, true)), false);
    for (const FlowPass& pass : plan.passes)
        for (const SubFlow& flow : pass.flows)
            if (isCoupledFlow(flow.kind)) {
                EXPECT_EQ(1u, pass.flows.size());
            }
    // The soft kick and its frozen part read the same forces.
    EXPECT_EQ((std::vector<int>{Soft, Stiff}), plan.slotGroups);
}

TEST(FlowSchedule, DescribeScheduleWritesTheStepInTheArchitectureNotation) {
    FlavorParameters p = artificial(FlavorIntegrator::Verlet, 0.002, 0.0005, false, false, 1.0);
    p.thermostatPlacement = FlavorIntegrator::Middle;
    p.kT = 2.494338785445972; // 300 K
    p.frozen = SubFlow::FrozenSet::Distances;
    EXPECT_EQ("K_S(δ) θ((δ−τ)/2) K_F(τ) D(τ/2) O(δ) D(τ/2) θ((δ−τ)/2)   [O: 300 K, 1/ps; θ holds the stiff bonded "
              "distances]",
              describeSchedule(flavorSchedule(p), Stiff, AllForceGroups, "δ", "τ"));
    ImpulseParameters sim{StochasticImpulseIntegrator::Yoshida4, 0.002, Stiff, AllForceGroups};
    EXPECT_EQ(
        "K_S(0.675604H) E(1.35121H) K_S(−0.175604H) E(−1.70241H) K_S(−0.175604H) E(1.35121H) K_S(0.675604H)   [E: "
        "zero modes 0 K, 0/ps, stiff modes 0 K, 0/ps]",
        describeSchedule(impulseSchedule(sim), Stiff, AllForceGroups, "H", ""));
    sim.splitting = StochasticImpulseIntegrator::Warped;
    sim.thermostatPlacement = StochasticImpulseIntegrator::Middle;
    EXPECT_EQ("K_S(H/2) E^ω̃M(H) K_S(H/2)   [E: zero modes 0 K, 0/ps, stiff modes 0 K, 0/ps]",
              describeSchedule(impulseSchedule(sim), Stiff, AllForceGroups, "H", ""));
}

// The Metropolis-adjusted step is the friction-free step between a ProposalStart and a ProposalTest of the integrated
// groups, with the thermostat over half the step on each side; the test draws one random stream.
TEST(FlowSchedule, MetropolisWrapsTheFrictionFreeStepBetweenHalfStepThermostats) {
    const double delta = 0.01, tau = 0.001;
    FlavorParameters adjusted = parameters(FlavorIntegrator::Verlet, delta, tau, 1.0);
    adjusted.metropolis = true;
    const Schedule core = flavorSchedule(parameters(FlavorIntegrator::Verlet, delta, tau));
    const Schedule s = flavorSchedule(adjusted);
    ASSERT_EQ(core.size() + 4, s.size());
    EXPECT_EQ(thermostat(delta / 2), s.front());
    EXPECT_EQ(thermostat(delta / 2), s.back());
    EXPECT_EQ((SubFlow{SubFlow::ProposalStart, 0.0, AllForceGroups, Bath{0.0, 1.0}}), s[1]);
    EXPECT_EQ((SubFlow{SubFlow::ProposalTest, 0.0, AllForceGroups, Bath{0.0, 1.0}}), s[s.size() - 2]);
    EXPECT_EQ(core, Schedule(s.begin() + 2, s.end() - 2));
    // Without friction no thermostat is left; the markers are kept though their length is 0.
    adjusted.friction = 0.0;
    const Schedule plain = flavorSchedule(adjusted);
    ASSERT_EQ(core.size() + 2, plain.size());
    EXPECT_EQ(SubFlow::ProposalStart, plain.front().kind);
    EXPECT_EQ(SubFlow::ProposalTest, plain.back().kind);
    const StepPlan plan = analyzeStep(s, false);
    EXPECT_EQ(3, plan.noiseStreams); // two thermostats and the test
    EXPECT_EQ(SubFlow::ProposalTest, plan.passes[plan.passes.size() - 2].flows[0].kind);
    EXPECT_EQ(1u, plan.passes[plan.passes.size() - 2].flows.size());
}

// The hard wall moves the SIM step's final positions before the velocity-only sub-flows that close it and sets the
// walled pairs' speeds at the step's end, with the stiff modes' bath for its thermal speed.
TEST(FlowSchedule, HardWallMovesTheFinalPositionsBeforeTheClosingKickAndSetsSpeedsAfterIt) {
    const SubFlow::Kind K = SubFlow::Kick, E = SubFlow::StiffFlow, W = SubFlow::HardWall, V = SubFlow::HardWallSpeed;
    const SubFlow::Kind FE = SubFlow::FilteredStiffFlow, FK = SubFlow::FilteredKick;
    using Splitting = StochasticImpulseIntegrator::Splitting;
    const std::vector<std::pair<Splitting, std::vector<SubFlow::Kind>>> cases = {
        {StochasticImpulseIntegrator::Strang, {K, E, W, K, V}},
        {StochasticImpulseIntegrator::LieTrotter, {E, W, K, V}},
        {StochasticImpulseIntegrator::Filtered, {FE, W, FK, V}},
        {StochasticImpulseIntegrator::Warped, {FE, W, FK, V}},
        {StochasticImpulseIntegrator::Yoshida4, {K, E, K, E, K, E, W, K, V}}};
    for (const auto& c : cases) {
        ImpulseParameters walled{c.first, 0.002, Stiff, AllForceGroups};
        walled.stiffBath = Bath{0.01, 20.0};
        const Schedule unwalled = impulseSchedule(walled);
        walled.maxDrudeDistance = 0.02;
        const Schedule s = impulseSchedule(walled);
        std::vector<SubFlow::Kind> kinds;
        Schedule rest;
        for (const SubFlow& f : s) {
            kinds.push_back(f.kind);
            if (f.kind == W || f.kind == V) {
                EXPECT_EQ(0.02, f.distance);
                EXPECT_EQ(0.002, f.h);
                EXPECT_EQ(0.01, f.stiffBath.kT);
            } else {
                rest.push_back(f);
            }
        }
        EXPECT_EQ(c.second, kinds) << c.first;
        EXPECT_EQ(unwalled, rest) << c.first;
    }
    // Without soft forces the step is the stiff flow alone, and the wall follows it.
    ImpulseParameters stiffOnly{StochasticImpulseIntegrator::Warped, 0.002, Stiff, Stiff};
    stiffOnly.maxDrudeDistance = 0.02;
    const Schedule s = impulseSchedule(stiffOnly);
    ASSERT_EQ(3u, s.size());
    EXPECT_EQ(E, s[0].kind);
    EXPECT_EQ(W, s[1].kind);
    EXPECT_EQ(V, s[2].kind);
    // The walled positions change no velocity: the pass before them leaves the velocity projection to the kick's.
    const StepPlan plan =
        analyzeStep(impulseSchedule([] {
                        ImpulseParameters p{StochasticImpulseIntegrator::Warped, 0.002, Stiff, AllForceGroups};
                        p.maxDrudeDistance = 0.02;
                        return p;
                    }()),
                    true);
    ASSERT_EQ(4u, plan.passes.size());
    EXPECT_TRUE(plan.passes[0].nextProjectsVelocities);
}

TEST(FlowSchedule, BoltzmannsConstantIsOpenMMs) {
    // kT of the schedules, the same double as OpenMM's integrators take (BOLTZ of its reference headers).
    EXPECT_EQ(BoltzmannKJPerMolK, BOLTZ);
}

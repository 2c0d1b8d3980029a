#ifndef OPENMM_FLAVORS_FLOW_SCHEDULE_H_
#define OPENMM_FLAVORS_FLOW_SCHEDULE_H_

#include "../FlavorIntegrator.h"
#include "../StochasticImpulseIntegrator.h"
#include "windowsExportFlavors.h"
#include <vector>

namespace FlavorPlugin {

/** The force-group mask that selects every group. */
constexpr int AllForceGroups = -1;

/**
 * One exact sub-flow of an integration step.  A step is a composition of these, applied left to right.
 */
struct SubFlow {
    enum Kind {
        /** v += h M^-1 F_groups(q) */
        Kick,
        /** q += h v */
        Drift,
        /** Exact Ornstein-Uhlenbeck flow of friction and noise over h. */
        Thermostat,
        /** Exact flow of the quadratic stiff potential with friction and noise, E(h, gamma). */
        StiffFlow,
        /**
         * The opening half kick of the Filtered (or Warped) splitting by the forces of groups, then E(h, gamma): the
         * half kick is scaled in each stiff mode (omega > 0) by the filter kappa of
         * StochasticImpulseIntegrator::Filtered (Warped: plain, and E flows at the warped frequencies), plain in the
         * zero modes and free particles.  The kick is applied as the flow's image of it, after the flow.
         */
        FilteredStiffFlow,
        /** The closing half kick of the Filtered (Warped) splitting by the forces of groups, as above. */
        FilteredKick,
        /** Exact flow of the quadratic stiff potential without friction or noise, E(h, 0). */
        HarmonicFlow,
        /**
         * Drift with the stiff degrees of freedom frozen, theta^tr(h): q += h P0 v, where P0 is the mass-orthogonal
         * projection onto the zero modes of the quadratic stiff potential; velocities (so the rates of the frozen
         * coordinates) are unchanged.
         */
        FrozenDrift,
        /** Kick along the zero modes of the quadratic stiff potential only: v += h P0 M^-1 F_groups(q). */
        FrozenKick
    };
    Kind kind;
    double h;
    /** The force groups of a Kick, FilteredStiffFlow or FilteredKick; unused otherwise. */
    int groups;
    bool operator==(const SubFlow& other) const { return kind == other.kind && h == other.h && groups == other.groups; }
};

typedef std::vector<SubFlow> Schedule;

/** The parameters that define a FLAVOR step. */
struct FlavorParameters {
    FlavorIntegrator::Scheme scheme;
    FlavorIntegrator::Averaging averaging;
    /** Artificial averagings: the fast microstep is HarmonicFlow instead of kicks and a drift. */
    bool exactFastFlow;
    double mesoStep, microStep;
    int stiffGroups;
    /** The force groups integrated at all (stiff and soft together). */
    int integrationGroups;
    double friction;
    bool stiffFriction;
    FlavorIntegrator::ThermostatPlacement thermostatPlacement;
    bool operator==(const FlavorParameters& o) const {
        return scheme == o.scheme && averaging == o.averaging && exactFastFlow == o.exactFastFlow &&
               mesoStep == o.mesoStep && microStep == o.microStep && stiffGroups == o.stiffGroups &&
               integrationGroups == o.integrationGroups && friction == o.friction && stiffFriction == o.stiffFriction &&
               thermostatPlacement == o.thermostatPlacement;
    }
};

/**
 * Builds the schedule of one FLAVOR mesostep (docs/ARCHITECTURE.md), already simplified.  The artificial averagings
 * (eq. (2.11) of the FLAVORS paper and its symmetric composition), with theta^eps(tau) the fast microstep:
 *
 *     SymplecticEuler:  K_soft(delta) theta^eps(tau) theta^tr(delta - tau),   theta^eps = D(tau) K_stiff(tau)
 *     Verlet:           K_soft(delta/2) theta^tr((delta-tau)/2) theta^eps(tau) theta^tr((delta-tau)/2)
 *                       K_soft(delta/2),                                      theta^eps = K_stiff(tau/2) D(tau)
 *                                                                                         K_stiff(tau/2)
 *
 * or theta^eps = E(tau, 0) with the exact fast flow.  ArtificialProjected splits each soft kick K_soft(h) into
 * K_soft(h tau/delta) and a FrozenKick over h (1 - tau/delta).  Thermostats are placed as for the nonintrusive
 * schemes: over the whole mesostep (O(tau) before the fast part and O(delta - tau) before the frozen drift for
 * SymplecticEuler, O(delta/2) at each end for Verlet) or, with stiff friction, for tau.  With the Middle placement
 * (Verlet, symplectic microstep only) the Verlet step is shifted cyclically and the thermostat sits in the middle of
 * the microstep's drift:
 *
 *     K_stiff(tau/2) theta^tr((delta-tau)/2) K_soft(delta) theta^tr((delta-tau)/2) K_stiff(tau/2) D(tau/2) O D(tau/2)
 */
OPENMM_EXPORT_FLAVORS Schedule flavorSchedule(const FlavorParameters& parameters);

/** The parameters that define a stochastic impulse step. */
struct ImpulseParameters {
    StochasticImpulseIntegrator::Splitting splitting;
    double stepSize;
    int stiffGroups;
    int integrationGroups;
    bool operator==(const ImpulseParameters& o) const {
        return splitting == o.splitting && stepSize == o.stepSize && stiffGroups == o.stiffGroups &&
               integrationGroups == o.integrationGroups;
    }
};

/**
 * Builds the schedule of one stochastic impulse step (docs/ARCHITECTURE.md): E(H) K_soft(H) (LieTrotter),
 * K_soft(H/2) E(H) K_soft(H/2) (Strang), Strang composed as S(c H) S((1-2c) H) S(c H) with c = 1/(2 - 2^(1/3))
 * (Yoshida4), or FilteredStiffFlow(H) FilteredKick(H) (Filtered and Warped; E(H) alone without soft groups).
 */
OPENMM_EXPORT_FLAVORS Schedule impulseSchedule(const ImpulseParameters& parameters);

/**
 * Removes zero-length sub-flows and kicks by no force group, and merges adjacent sub-flows that compose exactly into
 * one (two drifts, two kicks of the same groups, two Ornstein-Uhlenbeck flows, and two kicks of disjoint groups over
 * the same step, which are one kick by their union).
 */
OPENMM_EXPORT_FLAVORS Schedule simplifySchedule(const Schedule& schedule);

/**
 * Whether a sub-flow acts through the modes of the quadratic stiff potential (StiffFlow, HarmonicFlow, FrozenDrift,
 * FrozenKick, FilteredStiffFlow, FilteredKick); such a sub-flow is a pass of its own.
 */
OPENMM_EXPORT_FLAVORS bool isModeFlow(SubFlow::Kind kind);

/**
 * A run of sub-flows that act particle by particle with forces that are all evaluated at the positions where the
 * pass begins, so one parallel loop over particles executes it.
 */
struct FlowPass {
    std::vector<SubFlow> flows;
    /** For each flow, the index of the force slot a Kick or FrozenKick reads (-1 for other kinds). */
    std::vector<int> slots;
};

/**
 * A schedule split into passes, with the distinct kick force-group sets numbered as slots.
 */
struct StepPlan {
    std::vector<FlowPass> passes;
    std::vector<int> slotGroups;
};

/** Whether a sub-flow changes only velocities, particle by particle (a kick or a thermostat). */
OPENMM_EXPORT_FLAVORS bool isVelocityFlow(SubFlow::Kind kind);

/**
 * Splits a schedule into passes.  A pass ends before a kick that follows a drift (its forces need the new
 * positions).  With constraints (constrained = true) a pass is a single sub-flow or a run of kicks and thermostats,
 * so that constraints can be applied after it.
 */
OPENMM_EXPORT_FLAVORS StepPlan compileStepPlan(const Schedule& schedule, bool constrained);

} // namespace FlavorPlugin

#endif

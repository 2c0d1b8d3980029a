#ifndef OPENMM_FLAVORS_FLOW_SCHEDULE_H_
#define OPENMM_FLAVORS_FLOW_SCHEDULE_H_

#include "../FlavorIntegrator.h"
#include "../StochasticImpulseIntegrator.h"
#include "ExactModeFlow.h"
#include "windowsExportFlavors.h"
#include <string>
#include <vector>

namespace FlavorPlugin {

/** The force-group mask that selects every group. */
constexpr int AllForceGroups = -1;

/** A heat bath: thermal energy kT (kJ/mol) and friction (1/ps). */
struct Bath {
    double kT = 0.0, friction = 0.0;
    bool operator==(const Bath& o) const { return kT == o.kT && friction == o.friction; }
    bool operator!=(const Bath& o) const { return !(*this == o); }
};

/**
 * A step length as a combination of the integrator's two time scales, h = mesoSteps * delta + microSteps * tau (for
 * a SIM, delta is the step H and tau is not used), kept beside the number for describing a step in words.
 */
struct StepLength {
    double mesoSteps = 0.0, microSteps = 0.0;
    bool operator==(const StepLength& o) const { return mesoSteps == o.mesoSteps && microSteps == o.microSteps; }
};

/**
 * One exact sub-flow of an integration step, with every setting it needs.  A step is a composition of these, applied
 * left to right; docs/ARCHITECTURE.md lists the kinds, their notation and the executor of each.
 */
struct SubFlow {
    enum Kind {
        /** v += h M^-1 F_groups(q) */
        Kick,
        /** q += h v */
        Drift,
        /** Exact Ornstein-Uhlenbeck flow of friction and noise over h (bath). */
        Thermostat,
        /** Exact flow E(h) of the quadratic stiff potential, the zero modes in bath and the stiff ones in stiffBath. */
        StiffFlow,
        /**
         * The opening half kick of the Filtered or Warped splitting by the forces of groups, then E(h): the half kick
         * acts in each stiff mode as response says, plain in the zero modes and free particles.  The kick is applied
         * as the flow's image of it, after the flow.
         */
        FilteredStiffFlow,
        /** The closing half kick of the Filtered or Warped splitting by the forces of groups, as above. */
        FilteredKick,
        /** Exact flow of the quadratic stiff potential without friction or noise, E(h, 0). */
        HarmonicFlow,
        /**
         * Drift with the stiff degrees of freedom frozen, theta(h): the frozen coordinates (frozen) keep their values
         * and rates, everything else drifts.
         */
        FrozenDrift,
        /** Kick along the coordinates that are not frozen (frozen) only. */
        FrozenKick,
        /**
         * Opens a Metropolis proposal (h = 0): remembers the positions, velocities and the energy of the forces of
         * groups (the integrated ones), H = U + K.
         */
        ProposalStart,
        /**
         * Closes the proposal (h = 0): accepts the state with probability min(1, exp(-(H - H_start) / kT)), kT from
         * bath; otherwise puts back the state where the proposal started with its velocities reversed.
         */
        ProposalTest,
        /**
         * The hard wall of the stiff pairs (StochasticImpulseIntegrator::setMaxDrudeDistance), on the step's final
         * positions: every stiff component of two particles farther apart than distance is put back inside, its
         * overshoot reflected for the step h at the thermal speed of stiffBath; its velocities wait for HardWallSpeed.
         */
        HardWall,
        /**
         * The hard wall's velocities, after the step's closing kick: the pairs that HardWall put back in this step get
         * their relative radial velocity set to the thermal speed of stiffBath, pointing inward, as
         * DrudeLangevinIntegrator does.
         */
        HardWallSpeed
    };
    /** The frequency at which the stiff modes of a mode flow turn. */
    enum class StiffFrequency {
        /** Their own. */
        Exact,
        /** The warped frequency whose Strang step has the exact static response (the Warped splitting). */
        Warped
    };
    /** How the zero modes of a Filtered or Warped step flow. */
    enum class ZeroModeFlow {
        /** The exact free flow with friction between the half kicks. */
        Exact,
        /** Both half kicks first, then D(h/2) O(h) D(h/2), as LangevinMiddleIntegrator (the Middle placement). */
        Middle
    };
    /** How the half kicks of a Filtered or Warped step act in each stiff mode. */
    enum class KickResponse {
        /** Not a Filtered or Warped step. */
        None,
        /** Scaled by the filter kappa (the Filtered splitting); the flow is exact. */
        Scaled,
        /** Plain (the Warped splitting); the flow turns at the warped frequency. */
        Plain
    };
    /** What a FrozenDrift or FrozenKick holds. */
    enum class FrozenSet {
        None,
        /** The nonzero modes of a quadratic stiff potential (projection onto its zero modes). */
        StiffModes,
        /** The distances of the stiff bonded forces, beside the System's constraints (RATTLE steps). */
        Distances
    };
    Kind kind;
    double h;
    /** The force groups of a Kick, FrozenKick, FilteredStiffFlow or FilteredKick; 0 otherwise. */
    int groups;
    /** Thermostat: its bath.  Mode flows: the bath of the zero modes and of the particles outside stiff components. */
    Bath bath = {};
    /** Mode flows: the bath of the stiff modes. */
    Bath stiffBath = {};
    StiffFrequency frequency = StiffFrequency::Exact;
    /** Warped frequency: the limit on the angle omega~ h a stiff mode turns and whether its friction is scaled. */
    WarpedFlowSettings warp = {};
    ZeroModeFlow zeroModes = ZeroModeFlow::Exact;
    KickResponse response = KickResponse::None;
    FrozenSet frozen = FrozenSet::None;
    /**
     * A Kick of stiff groups with a stiff clock (FlavorIntegrator::setStiffClockParameter): its forces are evaluated
     * with the clock parameter at the step's stiff clock plus clock (ps), the stiff time elapsed in the step's
     * microstep where the kick acts (0 before the microstep's drift, tau after it).  Kicks without it leave the
     * parameter alone.
     */
    bool clocked = false;
    double clock = 0.0;
    /** HardWall and HardWallSpeed: the largest distance (nm) of a stiff pair. */
    double distance = 0.0;
    /** h in the integrator's time scales, for describeStep(); not part of what the sub-flow does (operator==). */
    StepLength length = {};
    bool operator==(const SubFlow& o) const {
        return kind == o.kind && h == o.h && groups == o.groups && bath == o.bath && stiffBath == o.stiffBath &&
               frequency == o.frequency && warp == o.warp && zeroModes == o.zeroModes && response == o.response &&
               frozen == o.frozen && clocked == o.clocked && clock == o.clock && distance == o.distance;
    }
    bool operator!=(const SubFlow& o) const { return !(*this == o); }
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
    /** The thermal energy (kJ/mol) of the Langevin FLAVORs. */
    double kT = 0.0;
    /** Artificial averagings: what freezes (measured from the stiff forces when the first step starts). */
    SubFlow::FrozenSet frozen = SubFlow::FrozenSet::StiffModes;
    /** Whether the kicks of stiff groups run on the stiff clock (a clock parameter is set). */
    bool stiffClock = false;
    /** Whether each step is a Metropolis-adjusted proposal (FlavorIntegrator::setMetropolis). */
    bool metropolis = false;
    bool operator==(const FlavorParameters& o) const {
        return scheme == o.scheme && averaging == o.averaging && exactFastFlow == o.exactFastFlow &&
               mesoStep == o.mesoStep && microStep == o.microStep && stiffGroups == o.stiffGroups &&
               integrationGroups == o.integrationGroups && friction == o.friction && stiffFriction == o.stiffFriction &&
               thermostatPlacement == o.thermostatPlacement && kT == o.kT && frozen == o.frozen &&
               stiffClock == o.stiffClock && metropolis == o.metropolis;
    }
};

/** The parameters of a FlavorIntegrator (kT from its temperature; frozen: the stiff modes, until measured). */
OPENMM_EXPORT_FLAVORS FlavorParameters flavorParameters(const FlavorIntegrator& integrator);

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
 * (Verlet, symplectic microstep only) the step opens with both kicks and puts the thermostat in the middle of the
 * microstep's drift:
 *
 *     K_soft(delta) theta^tr((delta-tau)/2) K_stiff(tau) D(tau/2) O D(tau/2) theta^tr((delta-tau)/2)
 *
 * Metropolis-adjusted (generalized hybrid Monte Carlo): O(delta/2) [P] O(delta/2), where the proposal P is the
 * step's deterministic part (the schedule without friction) between a ProposalStart and a ProposalTest.
 */
OPENMM_EXPORT_FLAVORS Schedule flavorSchedule(const FlavorParameters& parameters);

/** The parameters that define a stochastic impulse step. */
struct ImpulseParameters {
    StochasticImpulseIntegrator::Splitting splitting;
    double stepSize;
    int stiffGroups;
    int integrationGroups;
    StochasticImpulseIntegrator::ThermostatPlacement thermostatPlacement = StochasticImpulseIntegrator::Throughout;
    /** The bath of the zero modes and free particles, and that of the stiff modes. */
    Bath bath = {}, stiffBath = {};
    /** Whether each step is a Metropolis-adjusted proposal (StochasticImpulseIntegrator::setMetropolis). */
    bool metropolis = false;
    /** The hard wall of the stiff pairs (nm), 0 for none (StochasticImpulseIntegrator::setMaxDrudeDistance). */
    double maxDrudeDistance = 0.0;
    /** The Warped splitting's limit on omega~ H, 0 for none (StochasticImpulseIntegrator::setMaxWarpedPhase). */
    double maxWarpedPhase = 0.0;
    /** Whether Warped scales the stiff modes' friction (StochasticImpulseIntegrator::setWarpedFrictionScaling). */
    bool warpedFrictionScaling = false;
    bool operator==(const ImpulseParameters& o) const {
        return splitting == o.splitting && stepSize == o.stepSize && stiffGroups == o.stiffGroups &&
               integrationGroups == o.integrationGroups && thermostatPlacement == o.thermostatPlacement &&
               bath == o.bath && stiffBath == o.stiffBath && metropolis == o.metropolis &&
               maxDrudeDistance == o.maxDrudeDistance && maxWarpedPhase == o.maxWarpedPhase &&
               warpedFrictionScaling == o.warpedFrictionScaling;
    }
};

/** The parameters of a StochasticImpulseIntegrator (baths from its temperatures and frictions). */
OPENMM_EXPORT_FLAVORS ImpulseParameters impulseParameters(const StochasticImpulseIntegrator& integrator);

/**
 * Builds the schedule of one stochastic impulse step (docs/ARCHITECTURE.md): E(H) K_soft(H) (LieTrotter),
 * K_soft(H/2) E(H) K_soft(H/2) (Strang), Strang composed as S(c H) S((1-2c) H) S(c H) with c = 1/(2 - 2^(1/3))
 * (Yoshida4), or FilteredStiffFlow(H) FilteredKick(H) (Filtered: kicks scaled by kappa; Warped: plain kicks and the
 * warped frequency; Middle placement: zero modes as LangevinMiddleIntegrator; E(H) alone without soft groups).
 * Metropolis-adjusted: O(H/2) [P] O(H/2) as for the FLAVOR, P the splitting without friction.  With a hard wall,
 * HardWall follows the step's last sub-flow that moves positions (so the closing kick reads the forces of the walled
 * positions, which the next step reuses) and HardWallSpeed ends the step (so the walled pairs end it moving inward at
 * the thermal speed, the closing kick's radial part replaced as the wall replaces the rest of their radial motion).
 */
OPENMM_EXPORT_FLAVORS Schedule impulseSchedule(const ImpulseParameters& parameters);

/**
 * Throws an OpenMMException, naming the parameters and what is allowed, unless the parameters describe a step this
 * library has: the one place that decides which combinations of settings exist.
 */
OPENMM_EXPORT_FLAVORS void validateFlavorStep(const FlavorParameters& parameters);
/** As validateFlavorStep(), for a stochastic impulse step. */
OPENMM_EXPORT_FLAVORS void validateImpulseStep(const ImpulseParameters& parameters);
/**
 * Throws an OpenMMException, naming the setting that stops it and why, unless the Metropolis-adjusted step
 * (parameters.metropolis) has a proposal that is reversible and volume-preserving and a Boltzmann target; constrained
 * says whether the System has constraints.  Checked when a step starts.
 */
OPENMM_EXPORT_FLAVORS void validateMetropolis(const FlavorParameters& parameters, bool constrained);
/** As above, for a stochastic impulse step. */
OPENMM_EXPORT_FLAVORS void validateMetropolis(const ImpulseParameters& parameters, bool constrained);
/**
 * Throws, naming parameter ("splitting", "friction" or "stiffModeFriction") and its value, if the splitting is not
 * one of StochasticImpulseIntegrator::Splitting or is not defined with the friction coefficient (1/ps).
 */
OPENMM_EXPORT_FLAVORS void validateSplitting(StochasticImpulseIntegrator::Splitting splitting, double friction,
                                             const char* parameter);

/**
 * Removes zero-length sub-flows and kicks by no force group, and merges adjacent sub-flows that compose exactly into
 * one (two drifts, two kicks of the same groups, two Ornstein-Uhlenbeck flows of the same bath, two equal mode flows
 * without kicks, and two kicks of disjoint groups over the same step, which are one kick by their union).
 */
OPENMM_EXPORT_FLAVORS Schedule simplifySchedule(const Schedule& schedule);

/**
 * Whether a sub-flow acts through the modes of the quadratic stiff potential or on frozen coordinates (StiffFlow,
 * HarmonicFlow, FrozenDrift, FrozenKick, FilteredStiffFlow, FilteredKick), or on the whole state (ProposalStart,
 * ProposalTest, HardWall, HardWallSpeed): it couples particles, so it is a pass of its own.
 */
OPENMM_EXPORT_FLAVORS bool isCoupledFlow(SubFlow::Kind kind);

/** Whether a sub-flow changes only velocities, particle by particle (a kick or a thermostat). */
OPENMM_EXPORT_FLAVORS bool isVelocityFlow(SubFlow::Kind kind);

/**
 * A run of sub-flows that act particle by particle with forces that are all evaluated at the positions where the
 * pass begins, so one parallel loop over particles executes it; or one coupled sub-flow.  With what the passes around
 * it decide for it.
 */
struct FlowPass {
    std::vector<SubFlow> flows;
    /** For each flow, the index of the force slot it reads (-1 for kinds without forces). */
    std::vector<int> slots;
    /** For each flow, its random stream relative to the step's first stream (-1 for flows without noise streams). */
    std::vector<int> streams;
    /** A single kick that the StiffFlow or HarmonicFlow pass after it applies as it reads velocities (no pass). */
    bool fusedIntoNext = false;
    /**
     * The next pass is a kick, thermostat or FilteredKick, whose velocity projection covers this pass's velocities
     * too (the projection is linear at fixed positions): a stiff flow leaves its velocities unprojected.
     */
    bool nextProjectsVelocities = false;
    /**
     * Frozen flows: a later pass of the step fixes the velocities of the particles outside the frozen clusters anyway
     * (a kick or thermostat projects them, a drift's position constraint sets them to the chord), so this pass leaves
     * them unprojected.
     */
    bool othersFixedLater = false;
    /**
     * A constrained drift pass followed by a frozen flow: it projects its chord velocities, since the frozen flow
     * reads the rates of its frozen distances from velocities that satisfy the System's constraints.
     */
    bool projectsChordVelocities = false;
};

/** A schedule analysed into passes: the step as the engine executes it. */
struct StepPlan {
    std::vector<FlowPass> passes;
    /** The distinct force-group sets the step reads, numbered as slots. */
    std::vector<int> slotGroups;
    /** The random streams one step draws (each thermostat, stiff flow and proposal test has one). */
    int noiseStreams = 0;
};

/**
 * Analyses a schedule once, where it is built: splits it into passes (a pass ends before a kick that follows a
 * drift; a coupled flow is a pass of its own; with constraints (constrained = true) a pass is a single sub-flow or a
 * run of kicks and thermostats, so that constraints can be applied after it), numbers the force slots and noise
 * streams, and decides each pass's fusion and projection flags.
 */
OPENMM_EXPORT_FLAVORS StepPlan analyzeStep(const Schedule& schedule, bool constrained);

/**
 * The schedule as a line of text in the notation of docs/ARCHITECTURE.md, e.g.
 * "K_S(δ) θ((δ−τ)/2) K_F(τ) D(τ/2) O(δ) D(τ/2) θ((δ−τ)/2)"; stiffGroups and integrationGroups name the kicks,
 * mesoName and microName the two time scales ("δ" and "τ", or "H" and ""); numFrozen, if positive, how many
 * distances or stiff modes the frozen flows hold.
 */
OPENMM_EXPORT_FLAVORS std::string describeSchedule(const Schedule& schedule, int stiffGroups, int integrationGroups,
                                                   const std::string& mesoName, const std::string& microName,
                                                   int numFrozen = 0);

} // namespace FlavorPlugin

#endif

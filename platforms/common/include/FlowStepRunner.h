#ifndef OPENMM_FLAVORS_FLOW_STEP_RUNNER_H_
#define OPENMM_FLAVORS_FLOW_STEP_RUNNER_H_

#include "FrozenDistances.h"
#include "FrozenFlowTask.h"
#include "ParticleFlows.h"
#include "StiffFlowTask.h"
#include "StiffModes.h"
#include "internal/CounterRandom.h"
#include "internal/FlowSchedule.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <cstdint>
#include <iosfwd>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace OpenMM {
class ContextImpl;
class ReferenceConstraints;
} // namespace OpenMM

namespace FlavorPlugin {

/**
 * Executes a Schedule on the particle data of a Reference or CPU Context.  Forces are cached per force-group
 * set and valid until positions change, so each group set is evaluated once per distinct set of positions.
 * Constraints are applied as OpenMM's VerletIntegrator applies them: positions after each drift (with the
 * velocity corrected to the constrained displacement) and after each stiff flow (with the velocity change of the same
 * correction in the free flow), velocities after each kick or thermostat.  Virtual sites
 * are placed before each force evaluation and at the end of the step.  docs/ARCHITECTURE.md follows one step through
 * it.
 *
 * A constrained particle of a stiff component (the core of a Drude pair in rigid water) carries its component through
 * the constraint solve: it enters the solve with the inverse of its component's total mass, and every other particle
 * of the component moves by the correction of its carrier, so the component's internal (stiff) coordinates are left
 * exactly as the stiff flow made them.  The true constraint force acts on the carrier alone, and a share of it (its
 * carried particles' mass over the component's) moves the internal coordinates; that share enters the next step as a
 * soft force pair (on each carried particle and, opposite, on its carrier) from the constraint impulses of this
 * step, so the kicks, filtered or not, treat it like every other soft force.
 *
 * Filtered steps report processed velocities in the stiff modes: the closing kick subtracts beta times the change of
 * the soft force over the step (StiffModes::computeVelocityProcessing) and the next step adds it back before it
 * flows, so positions are those of the unprocessed scheme while velocities follow a steadily changing force exactly.
 * Both the shares and the processing are part of the integrator's checkpoint.
 */
class OPENMM_EXPORT_FLAVORS FlowStepRunner {
public:
    FlowStepRunner(const OpenMM::System& system, std::unique_ptr<ParallelLoop> loop);
    ~FlowStepRunner();
    /**
     * Sets the schedule of one step, the thermal energy kT (kJ/mol) and the friction (1/ps) of its thermostats.
     * Cheap when nothing changed.
     */
    void setSchedule(const Schedule& schedule, double kT, double friction);
    /**
     * Sets the decomposed stiff potential whose exact flow StiffFlow (friction and kT as given to setSchedule()) and
     * HarmonicFlow sub-flows apply, and whose zero modes FrozenDrift and FrozenKick move along.
     */
    void setStiffModes(std::shared_ptr<const StiffModes> modes);
    /**
     * Sets the thermal energy kT (kJ/mol) and friction (1/ps) of the stiff modes (omega > 0) in StiffFlow sub-flows;
     * a negative value means the one given to setSchedule().  Cheap when nothing changed.
     */
    void setStiffModeBath(double kT, double friction);
    /**
     * Sets how FilteredStiffFlow and FilteredKick sub-flows remove the impulse bias of the stiff modes: kicks scaled
     * by kappa with the exact flow (the Filtered splitting, the default) or plain kicks with the flow at the warped
     * frequencies (Warped).  Cheap when nothing changed.
     */
    void setBiasRemoval(StiffModes::BiasRemoval removal);
    /**
     * Sets whether the zero modes of FilteredStiffFlow passes flow as computeMiddleFreeFlow, with both of their half
     * kicks at the opening (the Middle thermostat placement), or exactly between the half kicks (the default).
     * Cheap when nothing changed.
     */
    void setMiddleZeroModes(bool middle);
    /**
     * Sets the frozen distances along which FrozenDrift and FrozenKick hold stiff bonded forces (instead of the
     * zero modes of a quadratic stiff potential); null returns to the modes.
     */
    void setFrozenDistances(std::shared_ptr<FrozenDistances> distances);
    /** Restricts the thermostats to the given particles; an empty list means every particle. */
    void setFrictionParticles(const std::vector<int>& particles);
    /** Sets the seed of the random streams and restarts them. */
    void setRandomSeed(std::uint64_t seed);
    /**
     * Takes one step and advances the Context's time by stepSize and its step count by one.  forcesValid says
     * whether forces cached in an earlier step may be reused; it is true on return.
     */
    void step(OpenMM::ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid);
    /** The kinetic energy of the current velocities (synchronous with positions). */
    double kineticEnergy(OpenMM::ContextImpl& context) const;
    /**
     * Writes the random streams (seed and stream counter) to a checkpoint, after a tag, the integrator's name and
     * the format version, and before an end tag.
     */
    void createCheckpoint(std::ostream& stream, const std::string& integratorName) const;
    /**
     * Reads what createCheckpoint() wrote for integratorName.  If the stream holds no such data (a checkpoint of
     * another integrator, of another format version, or a truncated one), the random streams are left unchanged,
     * the Context's state saved by saveContextState() is put back (OpenMM reads its own part of a checkpoint, and
     * overwrites the Context with it, before the integrator reads its part) and an OpenMMException says what the
     * stream holds.
     */
    void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream, const std::string& integratorName);
    /**
     * Remembers the Context's positions, velocities, periodic box, time and step count (no allocation after the
     * first call), and its parameters too when withParameters is true, for a failed loadCheckpoint() to put back.
     */
    void saveContextState(OpenMM::ContextImpl& context, bool withParameters);
    /**
     * Forgets what the next step would take from the last one (the constraint shares of carried components, the
     * velocity processing of Filtered steps): called when positions or velocities are set, after which the next step
     * starts as the first one does.  Between loadCheckpoint() and the next step it keeps the loaded history.
     */
    void forgetStepHistory();

private:
    struct ForceSlot {
        int groups;
        bool valid;
        std::vector<OpenMM::Vec3> forces;
    };
    void prepare();
    void ensureForces(OpenMM::ContextImpl& context, int slot);
    void invalidateForces();
    /**
     * Constrains positions (reference: the positions before the move) or velocities, carrying stiff components.  A
     * carrier's correction, times its component's mass and impulsePerCorrection (the impulse per unit correction: 1
     * for velocities), adds to its constraint impulse of this step.
     */
    void constrainPositions(OpenMM::ContextImpl& context, double tolerance, double impulsePerCorrection);
    void constrainVelocities(OpenMM::ContextImpl& context, double tolerance);
    /** Adds each carrier's correction (now minus carrierBefore) times its mass and scale to its step's impulse. */
    void addCarrierImpulses(const std::vector<OpenMM::Vec3>& corrected, double impulsePerCorrection);
    /** Turns the constraint impulses of a step of length stepSize into the shares of the next step, and resets them. */
    void updateConstraintShares(double stepSize);
    /** Kicks the particles of carried components by h times their constraint shares. */
    void kickConstraintShares(OpenMM::ContextImpl& context, double h);
    /** Runs a StiffFlow pass; kickForces, when not null, are the forces of the fused kick over kickStep before it. */
    void runStiffFlow(OpenMM::ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                      double constraintTolerance, const OpenMM::Vec3* kickForces, double kickStep);
    /** Adds the force response of pass passIndex to the forces of the flow's slot (FilteredKick). */
    void runFilteredKick(OpenMM::ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                         double constraintTolerance);
    /** Points a Filtered kick's response task at the velocity processing of pass passIndex. */
    void setProcessing(ForceResponseTask& task, size_t passIndex, bool closing);
    /** Runs a FrozenDrift or FrozenKick pass. */
    void runFrozenFlow(OpenMM::ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                       double constraintTolerance);

    std::unique_ptr<ParallelLoop> loop;
    int numParticles;
    bool hasConstraints, hasVirtualSites;
    std::vector<double> masses, inverseMasses, thermalSpeeds;
    // Per coordinate (three per particle), for the particle passes.
    std::vector<double> coordinateInverseMasses, coordinateMovable;
    // 1 for particles the thermostats act on, 0 for the others.
    std::vector<double> thermostated;
    std::vector<int> frictionParticles;
    Schedule schedule;
    double kT, friction;
    // Negative: as kT and friction.
    double stiffKT, stiffFriction;
    StiffModes::BiasRemoval biasRemoval = StiffModes::BiasRemoval::ScaledKicks;
    bool middleZeroModes = false;
    StepPlan plan;
    std::vector<std::vector<PreparedFlow>> preparedPasses;
    // For each pass, whether it is a single kick that the StiffFlow pass after it applies as it reads velocities.
    std::vector<bool> kickFusedIntoNext;
    // For each pass, whether the next one is a kick or thermostat, whose velocity projection then covers this pass's
    // velocities too.
    std::vector<bool> kickProjectsNext;
    // For each FrozenDrift or FrozenKick pass, whether a later pass of the step fixes the velocities of the particles
    // outside the frozen clusters anyway (a kick or thermostat projects them, a drift's position constraint absorbs
    // their normal part and sets them to the chord), so the frozen pass leaves them unprojected.
    std::vector<bool> otherVelocitiesFixedLater;
    // For each pass, whether the next one is a FrozenDrift or FrozenKick (a drift before it projects its velocities).
    std::vector<bool> frozenFlowNext;
    std::shared_ptr<const StiffModes> stiffModes;
    std::unique_ptr<StiffFlowTask> stiffFlowTask;
    std::unique_ptr<FrozenFlowTask> frozenFlowTask;
    std::shared_ptr<FrozenDistances> frozenDistances;
    // For each pass that is a StiffFlow, the exact flow over its step.
    std::vector<StiffModes::Propagator> stiffFlows;
    // For each FilteredStiffFlow or FilteredKick pass, its response to the forces of its slot.
    std::vector<StiffModes::ForceResponse> forceResponses;
    std::unique_ptr<ForceResponseTask> forceResponseTask;
    std::vector<ForceSlot> slots;
    std::vector<OpenMM::Vec3> previousPositions;
    // The positions after a stiff flow, before their constraint correction.
    std::vector<OpenMM::Vec3> unconstrainedPositions;
    // The System's particles and constraints (and angles, which CCMA uses), from which the solver of carried
    // constraints is built with each carrier's mass replaced by its component's.
    std::unique_ptr<OpenMM::System> constraintSystem;
    // When stiff components are constrained: the solver with carrier masses, its inverse masses, the (carried,
    // carrier) particle pairs and room for each carrier's coordinates before the solve.
    std::unique_ptr<OpenMM::ReferenceConstraints> carriedConstraints;
    std::vector<double> carriedInverseMasses;
    std::vector<std::pair<int, int>> carriedParticles;
    std::vector<OpenMM::Vec3> carrierBefore;
    // Per carried pair: its carrier's constraint impulse so far in this step.
    std::vector<OpenMM::Vec3> carrierImpulses;
    // The carried particles and their carriers, each once.
    std::vector<int> shareParticles;
    // The step history, per particle (checkpointed, forgotten when the Context's state is set): the constraint share
    // forces that the kicks of the next step add (zero outside carried components), and, for Filtered steps, the
    // change of the soft force on stiff particles over the last step, whose velocity processing the next step undoes.
    std::vector<OpenMM::Vec3> shareForces, forceDifferences;
    // Whether the history was read from a checkpoint since the last step (forgetStepHistory() then keeps it).
    bool historyLoaded = false;
    // The soft forces on stiff particles where the current Filtered step began.
    std::vector<OpenMM::Vec3> openingForces;
    // Whether the virtual sites are where the current positions put them (invalidateForces() clears it).
    bool virtualSitesPlaced = false;
    // For each FilteredStiffFlow or FilteredKick pass, its velocity processing (StiffModes::computeVelocityProcessing).
    std::vector<StiffModes::ForceResponse> processingResponses;
    int thermostatsPerStep;
    std::uint64_t seed, nextStream;
    CounterRandom random;
    // The Context's state as of the last saveContextState().
    struct SavedState {
        bool valid = false;
        std::vector<OpenMM::Vec3> positions, velocities;
        OpenMM::Vec3 boxSize, boxVectors[3];
        double time = 0.0;
        long long stepCount = 0;
        std::map<std::string, double> parameters;
    } saved;
    void restoreContextState(OpenMM::ContextImpl& context);
};

} // namespace FlavorPlugin

#endif

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
 * exactly as the stiff flow made them.
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

private:
    struct ForceSlot {
        int groups;
        bool valid;
        std::vector<OpenMM::Vec3> forces;
    };
    void prepare();
    void ensureForces(OpenMM::ContextImpl& context, int slot);
    void invalidateForces();
    /** Runs a StiffFlow pass; kickForces, when not null, are the forces of the fused kick over kickStep before it. */
    /** Constrains positions (reference: the positions before the move) or velocities, carrying stiff components. */
    void constrainPositions(OpenMM::ContextImpl& context, double tolerance);
    void constrainVelocities(OpenMM::ContextImpl& context, double tolerance);
    void runStiffFlow(OpenMM::ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                      double constraintTolerance, const OpenMM::Vec3* kickForces, double kickStep);
    /** Adds the force response of pass passIndex to the forces of the flow's slot (FilteredKick). */
    void runFilteredKick(OpenMM::ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                         double constraintTolerance);
    /** Runs a FrozenDrift or FrozenKick pass. */
    void runFrozenFlow(OpenMM::ContextImpl& context, const PreparedFlow& flow, double constraintTolerance);

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
    StepPlan plan;
    std::vector<std::vector<PreparedFlow>> preparedPasses;
    // For each pass, whether it is a single kick that the StiffFlow pass after it applies as it reads velocities.
    std::vector<bool> kickFusedIntoNext;
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

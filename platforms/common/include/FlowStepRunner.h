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
#include <memory>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/**
 * Executes a Schedule on the particle data of a Reference or CPU Context.  Forces are cached per force-group
 * set and valid until positions change, so each group set is evaluated once per distinct set of positions.
 * Constraints are applied as OpenMM's VerletIntegrator applies them: positions after each drift (with the
 * velocity corrected to the constrained displacement), velocities after each kick or thermostat.  Virtual sites
 * are placed before each force evaluation and at the end of the step.
 */
class OPENMM_EXPORT_FLAVORS FlowStepRunner {
public:
    FlowStepRunner(const OpenMM::System& system, std::unique_ptr<ParallelLoop> loop);
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
    void createCheckpoint(std::ostream& stream) const;
    void loadCheckpoint(std::istream& stream);

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
    void runStiffFlow(OpenMM::ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                      double constraintTolerance, const OpenMM::Vec3* kickForces, double kickStep);
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
    std::vector<ForceSlot> slots;
    std::vector<OpenMM::Vec3> previousPositions;
    int thermostatsPerStep;
    std::uint64_t seed, nextStream;
    CounterRandom random;
};

} // namespace FlavorPlugin

#endif

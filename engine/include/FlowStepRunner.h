#ifndef OPENMM_FLAVORS_FLOW_STEP_RUNNER_H_
#define OPENMM_FLAVORS_FLOW_STEP_RUNNER_H_

#include "ConstraintProjector.h"
#include "ContextRollback.h"
#include "FlowCheckpoint.h"
#include "FlowExecutors.h"
#include "ForceCache.h"
#include "FrozenDistances.h"
#include "ParticleFlows.h"
#include "ParticleTable.h"
#include "StepBackend.h"
#include "StepHistory.h"
#include "StiffClock.h"
#include "StiffModes.h"
#include "internal/CounterRandom.h"
#include "internal/FlowSchedule.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/**
 * Executes a Schedule on the particle data of a Reference or CPU Context: a loop over the passes of its StepPlan
 * (analyzeStep) that hands each pass to the executor of its kind (FlowExecutors.h), over a force cache, the System's
 * constraints (carried stiff components included), the step history and the random streams.  docs/ARCHITECTURE.md
 * follows one step through it.
 */
class OPENMM_EXPORT_FLAVORS FlowStepRunner : public StepBackend {
public:
    FlowStepRunner(const OpenMM::System& system, std::unique_ptr<ParallelLoop> loop);
    ~FlowStepRunner() override;
    /** Every kind of sub-flow has an executor here. */
    bool supports(SubFlow::Kind) const override { return true; }
    /** Sets the schedule of one step (each sub-flow with all of its settings).  Cheap when nothing changed. */
    void setSchedule(const Schedule& schedule) override;
    /**
     * Sets the decomposed stiff potential whose exact flow StiffFlow, HarmonicFlow and the Filtered sub-flows apply,
     * and whose zero modes FrozenDrift and FrozenKick on the stiff modes move along.
     */
    void setStiffModes(std::shared_ptr<const StiffModes> modes) override;
    /** Sets the frozen distances that FrozenDrift and FrozenKick on distances hold. */
    void setFrozenDistances(std::shared_ptr<FrozenDistances> distances);
    /** The nonzero modes of frozenModes (as setStiffModes()) or the distances (setFrozenDistances()) frozen. */
    void setFrozenCoordinates(std::shared_ptr<const StiffModes> frozenModes,
                              std::shared_ptr<FrozenDistances> distances) override;
    /** Restricts the thermostats to the given particles; an empty list means every particle. */
    void setFrictionParticles(const std::vector<int>& particles) override;
    /**
     * Runs the clocked kicks of the schedule on the stiff clock: the Context global parameter parameter is set before
     * their forces are evaluated; the clock advances microStep per step and starts (first step, time set from
     * outside) at the Context's time times microStep / mesoStep.  Cheap when nothing changed.
     */
    void setStiffClock(const std::string& parameter, double microStep, double mesoStep) override;
    /** Sets the seed of the random streams and restarts them. */
    void setRandomSeed(std::uint64_t seed);
    /**
     * Takes one step and advances the Context's time by stepSize and its step count by one.  forcesValid says
     * whether forces cached in an earlier step may be reused; it is true on return.
     */
    void step(OpenMM::ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid) override;
    /** The Metropolis-adjusted steps' proposals so far, and how many were accepted. */
    const ProposalCounts& getProposalCounts() const { return proposals.getCounts(); }
    /** The kinetic energy of the current velocities (synchronous with positions). */
    double kineticEnergy(OpenMM::ContextImpl& context) const;
    /**
     * Writes the random streams (seed and stream counter) and the step history to a checkpoint, after a tag, the
     * integrator's name and the format version, and before an end tag.
     */
    void createCheckpoint(std::ostream& stream, const std::string& integratorName) const;
    /**
     * Reads what createCheckpoint() wrote for integratorName.  If the stream holds no such data (a checkpoint of
     * another integrator, of another format version, or a truncated one), the random streams and history are left
     * unchanged, the Context's state saved by saveContextState() is put back and an OpenMMException says what the
     * stream holds.
     */
    void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream, const std::string& integratorName);
    /** Remembers the Context's state for a failed loadCheckpoint() to put back (ContextRollback). */
    void saveContextState(OpenMM::ContextImpl& context, bool withParameters);
    /**
     * Forgets what the next step would take from the last one (StepHistory): called when positions or velocities are
     * set, after which the next step starts as the first one does.  Between loadCheckpoint() and the next step it
     * keeps the loaded history.
     */
    void forgetStepHistory();

private:
    /** Analyses the schedule and lets every executor precompute its constants. */
    void prepare();
    /** The executor of each kind of sub-flow: the table docs/ARCHITECTURE.md shows. */
    FlowExecutor& executorFor(SubFlow::Kind kind);

    std::unique_ptr<ParallelLoop> loop;
    ParticleTable particles;
    ForceCache forces;
    std::unique_ptr<ConstraintProjector> constraints;
    StepHistory history;
    ContextRollback rollback;
    std::uint64_t seed = 0, nextStream = 0;
    StiffClock stiffClock;
    CounterRandom random;
    EngineParts parts;
    ParticlePassExecutor particlePasses;
    StiffFlowExecutor stiffFlows;
    FrozenFlowExecutor frozenFlows;
    ProposalExecutor proposals;
    HardWallExecutor hardWall;
    Schedule schedule;
    StepPlan plan;
    std::vector<FlowExecutor*> passExecutors;
};

} // namespace FlavorPlugin

#endif

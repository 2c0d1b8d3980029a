#ifndef OPENMM_FLAVORS_COMMON_FLAVOR_KERNELS_H_
#define OPENMM_FLAVORS_COMMON_FLAVOR_KERNELS_H_

#include "ConstraintProjector.h"
#include "ContextRollback.h"
#include "DeviceCarriedConstraints.h"
#include "DeviceFailureFlag.h"
#include "DeviceFrozenStage.h"
#include "DeviceHardWall.h"
#include "FlavorKernels.h"
#include "FrozenCoordinates.h"
#include "HardWall.h"
#include "HostFrozenStage.h"
#include "HostStateMirror.h"
#include "MetropolisTest.h"
#include "Mixed4Staging.h"
#include "ParticleFlows.h"
#include "ParticleTable.h"
#include "StepControl.h"
#include "StepHistory.h"
#include "StiffClock.h"
#include "StiffModes.h"
#include "StiffProbe.h"
#include "internal/CounterRandom.h"
#include "internal/FlowSchedule.h"
#include "openmm/System.h"
#include "openmm/common/ComputeArray.h"
#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeKernel.h"
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace FlavorPlugin {

/**
 * The step engine on a platform of OpenMM's common compute API (OpenCL; CUDA would use the same class): executes the
 * passes of a StepPlan with kernels from kernels/flowPasses.cc.  Kick, Drift and Thermostat passes, System
 * constraints and virtual sites through IntegrationUtilities, the exact stiff flow (StiffFlow, with a fused kick) and
 * the Filtered and Warped splittings' flows (FilteredStiffFlow, FilteredKick: the stiff flow and the force responses
 * with their velocity processing) one component per work-item; the same counter-based normals as CounterRandom, so a
 * double-precision trajectory follows the Reference one to rounding.  Force slots and the per-particle step history
 * that Filtered steps carry from one step to the next (StepHistory's force differences) live on the device in the
 * System's particle order, so they survive the Context's reordering of atoms; the history goes through the host
 * StepHistory for checkpoints, in the CPU engine's format.  Steps whose sub-flows it does not have yet are rejected by
 * setSchedule(), naming the setting that asks for them.
 *
 * With hostConstraints (the SIM) the System's constraints around the stiff flows and kicks follow the CPU engine's
 * ConstraintProjector, the one implementation of their math: around a stiff flow the constraint impulses on a
 * constrained particle of a stiff component reach the component's other particles through its flow, and a Filtered
 * step's velocities are processed for them (StepHistory's constraint processing).  Where SETTLE holds every such
 * particle (rigid Drude water) the solves run on the device (DeviceCarriedConstraints, with the projector's carrying
 * of each pass); elsewhere each such pass copies the positions and velocities to the host and back (HostStateMirror)
 * for the projector's solves.  Without hostConstraints, constraints are applied on the device by IntegrationUtilities.
 *
 * The artificial FLAVOR's frozen stage (FrozenDrift, FrozenKick) runs on the device where its clusters are small and
 * free of System constraints (DeviceFrozenStage: flexible water, one work-item per molecule); elsewhere (proteins,
 * frozen stiff modes) it runs the engine's host code on such copies (HostFrozenStage).  The SIM's hard wall runs on
 * the device (DeviceHardWall).  A kernel that finds a step cannot go on sets one flag on the device
 * (DeviceFailureFlag), read without waiting where the next step starts.  The particles' state for a failed checkpoint
 * to put back is kept on the device.  The Metropolis proposals are not here yet.
 */
class CommonFlowStepper : public StepBackend {
public:
    /** owner and platformName name the integrator and the platform in messages. */
    CommonFlowStepper(OpenMM::ComputeContext& cc, const OpenMM::System& system, std::string owner,
                      std::string platformName, bool hostConstraints = false);
    ~CommonFlowStepper() override;
    /** Every kind of sub-flow has kernels here. */
    bool supports(SubFlow::Kind) const override { return true; }
    /** Sets the schedule of one step; cheap when nothing changed. */
    void setSchedule(const Schedule& schedule) override;
    /** Sets the decomposed stiff potential that StiffFlow applies and uploads its constant parts. */
    void setStiffModes(std::shared_ptr<const StiffModes> modes) override;
    /**
     * Sets what FrozenDrift and FrozenKick hold: the nonzero modes of modes, or the distances (one of them null).
     * Those passes run on the host (HostFrozenStage).
     */
    void setFrozenCoordinates(std::shared_ptr<const StiffModes> frozenModes,
                              std::shared_ptr<FrozenDistances> distances) override;
    /** Restricts the thermostats to the given particles; an empty list means every particle. */
    void setFrictionParticles(const std::vector<int>& particles) override;
    /** Sets the seed of the random streams and restarts them. */
    void setRandomSeed(std::uint64_t seed);
    /**
     * Runs the clocked kicks on the stiff clock: the Context global parameter parameter is set before their forces
     * are evaluated ("" for none; FlavorIntegrator::setStiffClockParameter).
     */
    void setStiffClock(const std::string& parameter, double microStep, double mesoStep) override {
        stiffClock.configure(parameter, microStep, mesoStep);
    }
    /** Takes one step and advances the Context's time by stepSize and its step count by one. */
    void step(OpenMM::ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid) override;
    double kineticEnergy();
    void createCheckpoint(std::ostream& stream) const;
    void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream);
    /** Remembers the Context's state for a failed loadCheckpoint() to put back, the particles on the device. */
    void saveContextState(OpenMM::ContextImpl& context, bool withParameters);
    /** Forgets the step history as the CPU engine does (StepHistory::forget), on the device too. */
    void forgetStepHistory();
    /** The Metropolis-adjusted steps' proposals so far, and how many were accepted. */
    const ProposalCounts& getProposalCounts() const { return metropolis.getCounts(); }

private:
    /** Puts back the state saveContextState() remembered. */
    void restoreSavedState(OpenMM::ContextImpl& context);
    /** Analyses the schedule, checks that every sub-flow is supported and precomputes the constants of each pass. */
    void prepare();
    /** Evaluates the forces of a slot (virtual sites placed first) unless they are valid. */
    /** The forces of a slot at the current positions; a clocked kick's at the stiff clock value clock. */
    void ensureForces(OpenMM::ContextImpl& context, int slot, bool clocked = false, double clock = 0.0);
    void placeVirtualSites();
    /** Whether the System's constraints are solved on the device (deviceCarried) rather than by projector. */
    bool constraintsOnDevice() const { return projector && deviceCarried->isActive(); }
    /** Makes slotOf current (once per step). */
    void findAtoms();
    void invalidateForces();
    /** Copies the forces last evaluated into their slot if they still wait in the platform's buffer. */
    void copyPendingForces();
    void runParticlePass(const FlowPass& pass, size_t passIndex, double constraintTolerance);
    void runStiffFlow(const FlowPass& pass, size_t passIndex);
    /** With host constraints: remembers the positions where a stiff flow starts. */
    void rememberFlowStart();
    /**
     * With host constraints: the constraint correction after a stiff flow of pass passIndex, as the CPU engine's
     * StiffFlowExecutor makes it.
     */
    void constrainAfterFlow(const FlowPass& pass, size_t passIndex, double constraintTolerance);
    /** With host constraints: the velocity projection after kicks (after a FilteredKick with its carrying). */
    void constrainVelocitiesOnHost(double constraintTolerance,
                                   const ConstraintProjector::StiffFlowCarrying* carrying = nullptr);
    void runFrozenPass(const FlowPass& pass, double constraintTolerance);
    /** Whether pass p is a lone kick that the device frozen pass after it applies first (fusedSlot, fusedStep). */
    bool kickFusesIntoFrozenPass(size_t p) const;
    /**
     * A Metropolis proposal's start (the state kept on the device) or its test (the energies read, the start put
     * back with reversed velocities where it is rejected).
     */
    void runProposal(OpenMM::ContextImpl& context, const FlowPass& pass);
    /** The potential energy of the proposal's groups: its energy slots' and the rest evaluated on its own. */
    double proposalEnergy(OpenMM::ContextImpl& context);
    /** The hard wall (HardWall, HardWallSpeed) on the device (DeviceHardWall). */
    void runHardWall(const SubFlow& flow);
    /** Throws what a kernel of the last step left in the failure flag. */
    void checkDeviceFailure();
    /** Runs the force-response kernel of a pass (the second kernel of a FilteredStiffFlow, the only of a FilteredKick).
     */
    void runForceResponse(size_t passIndex, size_t kernelIndex);
    /**
     * One kernel for a pass of kicks, drifts and thermostats (particlePass), or none where the pass has another flow
     * or the System has constraints.
     */
    OpenMM::ComputeKernel createFusedPassKernel(const FlowPass& pass, size_t p);
    /** The stiffFlow kernel of pass p with its propagator, for a StiffFlow or FilteredStiffFlow. */
    OpenMM::ComputeKernel createStiffFlowKernel(const SubFlow& flow, size_t p);
    /** The forceResponse kernel of pass p with its responses, for a FilteredStiffFlow or FilteredKick. */
    OpenMM::ComputeKernel createForceResponseKernel(const SubFlow& flow, int slot, size_t p);
    /** Copies the device's force differences into the host history, or the host's onto the device. */
    void downloadHistory(StepHistory& target) const;
    void uploadHistory();
    /** Adds the key and ziggurat arguments of the random streams to a kernel. */
    void addRandomArgs(OpenMM::ComputeKernel& kernel);

    OpenMM::ComputeContext& cc;
    const OpenMM::System& system;
    std::string owner, platformName;
    int numParticles;
    bool hasConstraints, hasVirtualSites, virtualSitesPlaced = false;
    Schedule schedule;
    StepPlan plan;
    std::shared_ptr<const StiffModes> modes;
    std::vector<int> frictionParticles;
    bool frictionParticlesSet = false;
    std::uint64_t seed = 0, nextStream = 0;
    StepHistory history;
    ContextRollback rollback;

    OpenMM::ComputeProgram program;
    OpenMM::ComputeKernel copyForcesKernel, findAtomsKernel, driftDisplacementKernel, applyDisplacementKernel,
        snapshotKernel;
    // What saveContextState() remembers of the particles (system order): on the device, and the cell offsets.
    OpenMM::ComputeArray savedPositions, savedVelocities;
    std::vector<OpenMM::mm_int4> savedCellOffsets;
    std::vector<OpenMM::ComputeArray> slotForces;
    std::vector<bool> slotValid;
    // Per slot: the stiff clock value its forces were evaluated at, if any.
    std::vector<SlotClock> slotClock;
    StiffClock stiffClock;
    OpenMM::ComputeArray kn, wn, fn, thermalSpeed, thermostated, slotOf;
    // Per pass, per flow: the kernel with its arguments set (the stream of a thermostat is set per step).
    std::vector<std::vector<OpenMM::ComputeKernel>> passKernels;
    // Per pass: its flows as one kernel where it has one (createFusedPassKernel), with their table.
    std::vector<OpenMM::ComputeKernel> fusedPassKernels;
    std::vector<OpenMM::ComputeArray> fusedOps, fusedOpReals;
    // The stiff components: their table, particles, eigenvectors, masses, scratch, and per StiffFlow pass its
    // propagator with its offsets and whether it is noisy.
    OpenMM::ComputeArray components, componentLayout, componentParticles, eigenvectors, eigenvectorOffset, sqrtMass,
        scratch, scratchOffset;
    std::vector<OpenMM::ComputeArray> propagators, propagatorOffsets;
    std::vector<int> propagatorNoisy;
    // For the force responses: per component 1 if stiff and where its two values per mode start, 12 values per particle
    // of scratch, and per Filtered pass its response and velocity processing.
    OpenMM::ComputeArray componentStiff, responseOffset, responseScratch;
    std::vector<OpenMM::ComputeArray> responses, processings;
    // The step history on the device (system order): the force differences of the last step and the forces where the
    // current Filtered step began.  history's forceDifferences is a copy for checkpoints and forget().
    OpenMM::ComputeArray forceDifferences, openingForces;
    // The particles' constants and the host copies of their state, shared by every pass that runs on the host: the
    // frozen stage and the constraint solves.
    ParticleTable particles;
    HostStateMirror mirror;
    HostFrozenStage frozenStage;
    // The frozen stage of small clusters (flexible water) on the device; the others run on the host (frozenStage).
    std::unique_ptr<DeviceFrozenStage> deviceFrozen;
    // The SIM's hard wall on the device, over the pairs hardWall finds; its failures and the frozen stage's in one
    // flag.
    std::unique_ptr<DeviceHardWall> deviceWall;
    std::unique_ptr<DeviceFailureFlag> failureFlag;
    // The Metropolis adjustment: the accept test, the slots evaluated with their energy and the groups outside them,
    // the start state on the device, and the uniform numbers of the step's streams.
    MetropolisTest metropolis;
    std::vector<bool> energySlots;
    std::vector<double> slotEnergy;
    int groupsWithoutEnergySlot = 0;
    OpenMM::ComputeArray proposalPositions, proposalVelocities;
    OpenMM::ComputeKernel saveProposalKernel, rejectProposalKernel;
    CounterRandom random{0};
    // The SIM's constraint solves around its stiff flows on the device where SETTLE holds every carrier; else on the
    // host (projector, mirror).
    std::unique_ptr<DeviceCarriedConstraints> deviceCarried;
    bool atomsFound = false;
    // The atom order slotOf was made for (the platform's host copy of it).
    std::vector<int> slotOfOrder;
    HardWall hardWall;
    // With host constraints: the projector and, per stiff flow pass, how its correction moves the particles.
    std::unique_ptr<ConstraintProjector> projector;
    std::vector<ConstraintProjector::StiffFlowCarrying> carrying;
    // The host side of the history's transfers (scratch, so also for a const checkpoint).
    mutable Mixed4Staging staging;
    int fusedSlot = -1;
    // The slot whose forces were last evaluated and are still only in the platform's force buffer (-1: none).
    int slotInBuffer = -1;
    double fusedStep = 0.0;
};

/**
 * The FlavorIntegrator kernel of the common compute platforms: the nonintrusive averaging on the device, the artificial
 * ones with their frozen stage on the device (DeviceFrozenStage) or, for clusters it does not take, on the host
 * (HostFrozenStage).
 */
class CommonFlavorStepKernel : public IntegrateFlavorStepKernel {
public:
    CommonFlavorStepKernel(std::string name, const OpenMM::Platform& platform, OpenMM::ComputeContext& cc)
        : IntegrateFlavorStepKernel(name, platform), cc(cc) {}
    void initialize(const OpenMM::System& system, const FlavorIntegrator& integrator) override;
    void execute(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                 bool& stiffModesValid) override;
    double computeKineticEnergy(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator) override;
    void createCheckpoint(OpenMM::ContextImpl& context, std::ostream& stream) const override;
    void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream) override;
    void saveContextState(OpenMM::ContextImpl& context, bool withParameters) override;
    void forgetStepHistory() override;
    void getProposalCounts(long long& proposed, long long& accepted) const override {
        proposed = (long long)stepper->getProposalCounts().proposed;
        accepted = (long long)stepper->getProposalCounts().accepted;
    }
    int getFrozenSet() const override { return control ? (int)control->getFrozenCoordinates().getFrozenSet() : 0; }
    int getNumFrozen() const override { return control ? control->getFrozenCoordinates().getNumFrozen() : 0; }

private:
    OpenMM::ComputeContext& cc;
    std::unique_ptr<CommonFlowStepper> stepper;
    std::unique_ptr<FlavorStepControl> control;
};

/**
 * The StochasticImpulseIntegrator kernel of the common compute platforms: the LieTrotter, Strang, Yoshida4, Filtered
 * and Warped steps.
 */
class CommonImpulseStepKernel : public IntegrateStochasticImpulseStepKernel {
public:
    CommonImpulseStepKernel(std::string name, const OpenMM::Platform& platform, OpenMM::ComputeContext& cc)
        : IntegrateStochasticImpulseStepKernel(name, platform), cc(cc) {}
    void initialize(const OpenMM::System& system, const StochasticImpulseIntegrator& integrator) override;
    void execute(OpenMM::ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                 bool& stiffModesValid) override;
    std::vector<double> getStiffModeFrequencies(OpenMM::ContextImpl& context,
                                                const StochasticImpulseIntegrator& integrator,
                                                bool& stiffModesValid) override;
    std::vector<double> getWarpedPhaseChoice(OpenMM::ContextImpl& context,
                                             const StochasticImpulseIntegrator& integrator,
                                             bool& stiffModesValid) override;
    double computeKineticEnergy(OpenMM::ContextImpl& context, const StochasticImpulseIntegrator& integrator) override;
    void createCheckpoint(OpenMM::ContextImpl& context, std::ostream& stream) const override;
    void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream) override;
    void saveContextState(OpenMM::ContextImpl& context, bool withParameters) override;
    void forgetStepHistory() override;
    void getProposalCounts(long long& proposed, long long& accepted) const override {
        proposed = (long long)stepper->getProposalCounts().proposed;
        accepted = (long long)stepper->getProposalCounts().accepted;
    }

private:
    OpenMM::ComputeContext& cc;
    std::unique_ptr<CommonFlowStepper> stepper;
    std::unique_ptr<ImpulseStepControl> control;
};

} // namespace FlavorPlugin

#endif

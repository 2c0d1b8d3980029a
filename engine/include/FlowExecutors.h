#ifndef OPENMM_FLAVORS_FLOW_EXECUTORS_H_
#define OPENMM_FLAVORS_FLOW_EXECUTORS_H_

#include "ConstraintProjector.h"
#include "FlowCheckpoint.h"
#include "ForceCache.h"
#include "FrozenDistances.h"
#include "FrozenFlowTask.h"
#include "HardWall.h"
#include "MetropolisTest.h"
#include "ParticleFlows.h"
#include "ParticleTable.h"
#include "StepHistory.h"
#include "StiffFlowTask.h"
#include "StiffModes.h"
#include "internal/CounterRandom.h"
#include "internal/FlowSchedule.h"
#include "openmm/Vec3.h"
#include <cstdint>
#include <memory>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/** The parts of the step engine that the executors share (owned by FlowStepRunner). */
struct EngineParts {
    const ParticleTable& particles;
    ParallelLoop& loop;
    ForceCache& forces;
    /** Null without System constraints. */
    ConstraintProjector* constraints;
    StepHistory& history;
    const CounterRandom& random;
    /** The decomposed quadratic stiff potential, if measured. */
    std::shared_ptr<const StiffModes> modes;
    /** The frozen distances of stiff bonded forces, if the artificial FLAVOR holds them. */
    std::shared_ptr<FrozenDistances> distances;
};

/** One step in progress. */
struct StepState {
    OpenMM::ContextImpl& context;
    double constraintTolerance;
    /** The step's first random stream; a flow's stream is this plus its offset in the plan. */
    std::uint64_t firstStream;
    /** A kick the next stiff flow applies as it reads velocities (FlowPass::fusedIntoNext): its forces and step. */
    const OpenMM::Vec3* fusedKickForces = nullptr;
    double fusedKickStep = 0.0;
    /** The stiff clock where the step starts (ps); a clocked kick reads forces at this plus its SubFlow::clock. */
    double stiffClock = 0.0;
};

/**
 * Executes the passes of one family of sub-flow kinds.  prepare() precomputes their constants for a plan (when the
 * plan, the baths or the stiff modes change), so that run() allocates nothing.
 */
class FlowExecutor {
public:
    explicit FlowExecutor(EngineParts& parts) : parts(parts) {}
    virtual ~FlowExecutor() = default;
    virtual void prepare(const StepPlan& plan) = 0;
    virtual void run(const FlowPass& pass, size_t passIndex, StepState& state) = 0;

protected:
    EngineParts& parts;
};

/** Kick, Drift and Thermostat: one loop over particles (ParticlePass) per pass, then the constraints. */
class ParticlePassExecutor : public FlowExecutor {
public:
    explicit ParticlePassExecutor(EngineParts& parts);
    void prepare(const StepPlan& plan) override;
    void run(const FlowPass& pass, size_t passIndex, StepState& state) override;
    /** Restricts the thermostats to the given particles; an empty list means every particle. */
    void setFrictionParticles(const std::vector<int>& particles);

private:
    std::vector<std::vector<PreparedFlow>> prepared;
    std::vector<double> thermalSpeeds;
    // 1 for particles the thermostats act on, 0 for the others.
    std::vector<double> thermostated;
    std::vector<int> frictionParticles;
};

/**
 * StiffFlow, HarmonicFlow, FilteredStiffFlow and FilteredKick: the exact flow of the quadratic stiff potential
 * (StiffFlowTask) and the Filtered and Warped steps' kick responses (ForceResponseTask), mode by mode.
 */
class StiffFlowExecutor : public FlowExecutor {
public:
    explicit StiffFlowExecutor(EngineParts& parts) : FlowExecutor(parts) {}
    void prepare(const StepPlan& plan) override;
    void run(const FlowPass& pass, size_t passIndex, StepState& state) override;

private:
    void runFlow(const FlowPass& pass, size_t passIndex, StepState& state);
    void runClosingKick(const SubFlow& flow, int slot, size_t passIndex, StepState& state);
    /** Points a response task at the velocity processing of pass passIndex. */
    void setProcessing(size_t passIndex, bool closing);
    const StiffModes* preparedFor = nullptr;
    std::unique_ptr<StiffFlowTask> flowTask;
    std::unique_ptr<ForceResponseTask> responseTask;
    // Per pass: the exact flow over its step, the Filtered response to the forces of its slot and the velocity
    // processing (StiffModes), and how a constraint correction at the start of the flow moves the particles.
    std::vector<StiffModes::Propagator> propagators;
    std::vector<StiffModes::ForceResponse> responses, processing;
    std::vector<ConstraintProjector::StiffFlowCarrying> carrying;
};

/** FrozenDrift and FrozenKick: along the zero modes of the stiff potential, or with the stiff distances held. */
class FrozenFlowExecutor : public FlowExecutor {
public:
    explicit FrozenFlowExecutor(EngineParts& parts) : FlowExecutor(parts) {}
    void prepare(const StepPlan& plan) override;
    void run(const FlowPass& pass, size_t passIndex, StepState& state) override;

private:
    void runOnDistances(const FlowPass& pass, StepState& state);
    void runOnStiffModes(const FlowPass& pass, StepState& state);
    const StiffModes* preparedFor = nullptr;
    std::unique_ptr<FrozenFlowTask> task;
};

/**
 * ProposalStart and ProposalTest: the proposal of a Metropolis-adjusted step.  The start remembers the state and its
 * energy H = U + K; the test accepts the proposed state with probability min(1, exp(-(H - H_start) / kT)), or puts
 * back the start with its velocities reversed.  U, the energy of the integrated groups, comes with the forces of
 * the slots that make it up (energySlots()), which the step reads anyway, and is carried from one test to the next
 * start; what no slot covers is evaluated on its own.
 */
class ProposalExecutor : public FlowExecutor {
public:
    explicit ProposalExecutor(EngineParts& parts) : FlowExecutor(parts) {}
    void prepare(const StepPlan& plan) override;
    void run(const FlowPass& pass, size_t passIndex, StepState& state) override;
    /** The state changed from outside (positions, parameters, a checkpoint): the next start evaluates its energy. */
    void forgetEnergy() { metropolis.forgetEnergy(); }
    const ProposalCounts& getCounts() const { return metropolis.getCounts(); }
    void setCounts(const ProposalCounts& stored) { metropolis.setCounts(stored); }

private:
    double totalEnergy(OpenMM::ContextImpl& context);
    std::vector<int> slotsWithEnergy;
    int groupsWithoutSlot = 0;
    std::vector<OpenMM::Vec3> startPositions, startVelocities;
    MetropolisTest metropolis;
};

/**
 * HardWall and HardWallSpeed: the hard wall of the stiff pairs (the stiff components of two particles, a Drude
 * particle, the lighter, and its parent), as DrudeLangevinIntegrator::setMaxDrudeDistance applies it: a pair farther
 * apart than the wall at the step's final positions is put back inside (HardWall, before the closing kick), and after
 * the kick its relative radial velocity is set to the thermal speed of the stiff modes, pointing inward, with the
 * pair's centre-of-mass velocity kept (HardWallSpeed).  A parent that is constrained or massless keeps its position
 * and velocity, and the Drude particle moves inward relative to it.
 */
class HardWallExecutor : public FlowExecutor {
public:
    explicit HardWallExecutor(EngineParts& parts) : FlowExecutor(parts) {}
    void prepare(const StepPlan& plan) override;
    void run(const FlowPass& pass, size_t passIndex, StepState& state) override;

private:
    HardWall wall;
};

} // namespace FlavorPlugin

#endif

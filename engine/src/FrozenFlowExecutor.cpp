#include "FlowExecutors.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

void FrozenFlowExecutor::prepare(const StepPlan& /*plan*/) {
    const StiffModes* modes = parts.modes.get();
    if (modes != preparedFor) {
        task = modes ? std::make_unique<FrozenFlowTask>(*modes) : nullptr;
        preparedFor = modes;
    }
}

void FrozenFlowExecutor::run(const FlowPass& pass, size_t /*passIndex*/, StepState& state) {
    // Frozen passes hold one sub-flow each (analyzeStep).
    if (pass.flows[0].frozen == SubFlow::FrozenSet::Distances)
        runOnDistances(pass, state);
    else
        runOnStiffModes(pass, state);
}

void FrozenFlowExecutor::runOnDistances(const FlowPass& pass, StepState& state) {
    if (!parts.distances)
        throw OpenMMException("FlowStepRunner: a frozen flow on distances needs setFrozenDistances()");
    // The System's constraints are part of the frozen distances' solver.
    const SubFlow& flow = pass.flows[0];
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(state.context.getPlatformData());
    const bool projectOthers = !pass.othersFixedLater;
    if (flow.kind == SubFlow::FrozenDrift) {
        parts.distances->drift(*data.positions, *data.velocities, parts.particles.inverseMasses, flow.h,
                               state.constraintTolerance, projectOthers, parts.loop);
        parts.forces.invalidate();
    } else {
        const vector<Vec3>& forces = parts.forces.get(state.context, pass.slots[0]);
        parts.distances->kick(*data.positions, *data.velocities, forces, parts.particles.inverseMasses, flow.h,
                              state.constraintTolerance, projectOthers, parts.loop);
    }
}

void FrozenFlowExecutor::runOnStiffModes(const FlowPass& pass, StepState& state) {
    if (!parts.modes)
        throw OpenMMException("FlowStepRunner: a frozen flow on the stiff modes needs setStiffModes()");
    const SubFlow& flow = pass.flows[0];
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(state.context.getPlatformData());
    vector<Vec3>& positions = *data.positions;
    vector<Vec3>& velocities = *data.velocities;
    ConstraintProjector* constraints = parts.constraints;
    const ParticleTable& particles = parts.particles;
    task->h = flow.h;
    if (flow.kind == SubFlow::FrozenDrift) {
        if (constraints)
            constraints->rememberPositions(positions);
        task->source = velocities.data();
        task->target = positions.data();
        task->sourceIsForce = false;
        parts.loop.run(*task, parts.modes->getNumComponents());
        parts.forces.invalidate();
        if (constraints) {
            // Constrained particles belong to no stiff component (StiffModesMeasurement): for them this was a plain
            // drift, and their velocities take the constrained displacement as after any drift.  The velocities of
            // stiff particles keep the rates of their frozen coordinates.
            constraints->constrainPositions(state.context, state.constraintTolerance);
            const vector<Vec3>& before = constraints->getReferencePositions();
            const double inverseTime = 1.0 / flow.h;
            for (int i = 0; i < particles.numParticles; ++i)
                if (particles.inverseMasses[i] != 0.0 && !parts.modes->isStiffParticle(i))
                    velocities[i] = (positions[i] - before[i]) * inverseTime;
        }
    } else {
        task->source = parts.forces.get(state.context, pass.slots[0]).data();
        task->target = velocities.data();
        task->sourceIsForce = true;
        parts.loop.run(*task, parts.modes->getNumComponents());
        if (constraints)
            constraints->constrainVelocities(state.context, state.constraintTolerance);
    }
}

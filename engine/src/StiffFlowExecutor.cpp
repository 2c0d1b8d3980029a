#include "FlowExecutors.h"
#include "internal/ExactModeFlow.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

void StiffFlowExecutor::prepare(const StepPlan& plan) {
    const StiffModes* modes = parts.modes.get();
    if (modes != preparedFor) {
        flowTask = modes ? std::make_unique<StiffFlowTask>(*modes) : nullptr;
        responseTask = modes ? std::make_unique<ForceResponseTask>(*modes) : nullptr;
        preparedFor = modes;
    }
    const size_t n = plan.passes.size();
    propagators.assign(n, StiffModes::Propagator());
    responses.assign(n, StiffModes::ForceResponse());
    processing.assign(n, StiffModes::ForceResponse());
    carrying.clear();
    carrying.resize(n);
    for (size_t p = 0; p < n; ++p) {
        const SubFlow& flow = plan.passes[p].flows[0];
        const bool filtered = flow.kind == SubFlow::FilteredStiffFlow || flow.kind == SubFlow::FilteredKick;
        const bool flows = flow.kind == SubFlow::StiffFlow || flow.kind == SubFlow::FilteredStiffFlow ||
                           flow.kind == SubFlow::HarmonicFlow;
        if (modes && flows)
            modes->computeFlowPropagator(flow, propagators[p]);
        if (modes && filtered)
            modes->computeFlowResponses(flow, responses[p], processing[p]);
        if (ConstraintProjector::hasCarrying(flow) && modes && parts.constraints)
            carrying[p] = parts.constraints->carryingThrough(*modes, flow);
    }
}

void StiffFlowExecutor::run(const FlowPass& pass, size_t passIndex, StepState& state) {
    // Passes over stiff components hold one sub-flow each (analyzeStep).
    const SubFlow& flow = pass.flows[0];
    if (!parts.modes)
        throw OpenMMException("FlowStepRunner: a " +
                              std::string(flow.kind == SubFlow::FilteredKick ? "FilteredKick" : "stiff flow") +
                              " needs the stiff modes (setStiffModes())");
    if (flow.kind == SubFlow::FilteredKick)
        runClosingKick(flow, pass.slots[0], passIndex, state);
    else
        runFlow(pass, passIndex, state);
}

void StiffFlowExecutor::runFlow(const FlowPass& pass, size_t passIndex, StepState& state) {
    const SubFlow& flow = pass.flows[0];
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(state.context.getPlatformData());
    vector<Vec3>& positions = *data.positions;
    vector<Vec3>& velocities = *data.velocities;
    const ParticleTable& particles = parts.particles;
    const bool filtered = flow.kind == SubFlow::FilteredStiffFlow;
    // A Filtered flow adds the response to the forces where it begins, after the flow.
    const Vec3* openingForces = filtered ? parts.forces.get(state.context, pass.slots[0]).data() : nullptr;
    if (parts.constraints)
        parts.constraints->rememberPositions(positions);
    StiffFlowTask& task = *flowTask;
    task.propagator = &propagators[passIndex];
    task.positions = positions.data();
    task.velocities = velocities.data();
    task.random = &parts.random;
    task.stream = state.firstStream + (std::uint64_t)std::max(0, pass.streams[0]);
    task.kickForces = filtered ? nullptr : state.fusedKickForces;
    task.inverseMasses = particles.inverseMasses.data();
    task.kickStep = filtered ? 0.0 : state.fusedKickStep;
    parts.loop.run(task, parts.modes->getNumComponents());
    if (!filtered)
        state.fusedKickForces = nullptr;
    if (filtered) {
        ForceResponseTask& response = *responseTask;
        response.response = &responses[passIndex];
        response.forces = openingForces;
        // It also undoes the velocity processing of the last closing kick, in the flow's image.
        setProcessing(passIndex, false);
        response.positions = positions.data();
        response.velocities = velocities.data();
        parts.loop.run(response, parts.modes->getNumComponents());
    }
    parts.forces.invalidate();
    if (!parts.constraints)
        return;
    // The correction of the positions is an impulse at the start of the flow (as in RATTLE): it changes the
    // velocities, and those of a constrained particle's stiff component through the component's flow.  The
    // projection after it removes what is left along the constraints.
    parts.constraints->constrainPositions(state.context, state.constraintTolerance, &carrying[passIndex]);
    if (!pass.nextProjectsVelocities)
        parts.constraints->constrainVelocities(state.context, state.constraintTolerance, &carrying[passIndex]);
}

void StiffFlowExecutor::runClosingKick(const SubFlow& /*flow*/, int slot, size_t passIndex, StepState& state) {
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(state.context.getPlatformData());
    ForceResponseTask& response = *responseTask;
    response.response = &responses[passIndex];
    response.forces = parts.forces.get(state.context, slot).data();
    // With the velocity processing: beta times the change of the soft force over the step off the stiff modes.
    setProcessing(passIndex, true);
    response.positions = data.positions->data();
    response.velocities = data.velocities->data();
    parts.loop.run(response, parts.modes->getNumComponents());
    if (!parts.constraints)
        return;
    // The step ends here: its velocities take the constraint impulses' processing, then the projection.
    if (!carrying[passIndex].processing.empty())
        parts.constraints->processVelocities(*data.velocities, carrying[passIndex], parts.history.constraintProcessing);
    parts.constraints->constrainVelocities(state.context, state.constraintTolerance, &carrying[passIndex]);
}

void StiffFlowExecutor::setProcessing(size_t passIndex, bool closing) {
    ForceResponseTask& task = *responseTask;
    task.processing = &processing[passIndex];
    task.closing = closing;
    task.openingForces = parts.history.openingForces.data();
    task.forceChanges = parts.history.forceDifferences.data();
}

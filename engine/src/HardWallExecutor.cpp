#include "FlowExecutors.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"

using namespace FlavorPlugin;
using namespace OpenMM;

void HardWallExecutor::prepare(const StepPlan& /*plan*/) {
    wall.setStiffModes(parts.modes.get(), parts.particles);
}

void HardWallExecutor::run(const FlowPass& pass, size_t /*passIndex*/, StepState& state) {
    const SubFlow& flow = pass.flows[0];
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(state.context.getPlatformData());
    if (flow.kind == SubFlow::HardWallSpeed)
        wall.setSpeeds(*data.velocities, parts.particles.masses, flow.stiffBath.kT);
    else if (wall.movePositions(*data.positions, parts.particles.masses, flow.distance, flow.h, flow.stiffBath.kT))
        parts.forces.invalidate();
}

#include "internal/FlowSchedule.h"
#include <algorithm>

using namespace FlavorPlugin;

namespace {

bool readsForces(SubFlow::Kind kind) {
    return kind == SubFlow::Kick || kind == SubFlow::FrozenKick || kind == SubFlow::FilteredStiffFlow ||
           kind == SubFlow::FilteredKick;
}

bool drawsNoise(SubFlow::Kind kind) {
    return kind == SubFlow::Thermostat || kind == SubFlow::StiffFlow || kind == SubFlow::FilteredStiffFlow ||
           kind == SubFlow::ProposalTest;
}

bool isFrozenFlow(SubFlow::Kind kind) {
    return kind == SubFlow::FrozenDrift || kind == SubFlow::FrozenKick;
}

} // namespace

StepPlan FlavorPlugin::analyzeStep(const Schedule& schedule, bool constrained) {
    StepPlan plan;
    bool driftedInPass = false, onlyVelocityFlowsInPass = false;
    for (const SubFlow& flow : schedule) {
        const bool previousWasCoupled = !plan.passes.empty() && isCoupledFlow(plan.passes.back().flows.back().kind);
        // With constraints only kicks and thermostats share a pass: one velocity projection after all of them is
        // the same as one after each (the projection is linear at fixed positions).
        const bool joinsUnderConstraints = isVelocityFlow(flow.kind) && onlyVelocityFlowsInPass;
        const bool newPass = plan.passes.empty() || (constrained && !joinsUnderConstraints) ||
                             isCoupledFlow(flow.kind) || previousWasCoupled ||
                             (flow.kind == SubFlow::Kick && driftedInPass);
        if (newPass) {
            plan.passes.emplace_back();
            driftedInPass = false;
            onlyVelocityFlowsInPass = true;
        }
        onlyVelocityFlowsInPass = onlyVelocityFlowsInPass && isVelocityFlow(flow.kind);
        int slot = -1;
        if (readsForces(flow.kind)) {
            auto found = std::find(plan.slotGroups.begin(), plan.slotGroups.end(), flow.groups);
            slot = (int)(found - plan.slotGroups.begin());
            if (found == plan.slotGroups.end())
                plan.slotGroups.push_back(flow.groups);
        }
        driftedInPass = driftedInPass || flow.kind == SubFlow::Drift;
        FlowPass& pass = plan.passes.back();
        pass.flows.push_back(flow);
        pass.slots.push_back(slot);
        pass.streams.push_back(drawsNoise(flow.kind) ? plan.noiseStreams++ : -1);
    }
    const size_t n = plan.passes.size();
    for (size_t p = 0; p + 1 < n; ++p) {
        FlowPass& pass = plan.passes[p];
        const SubFlow::Kind next = plan.passes[p + 1].flows[0].kind;
        // The hard wall's positions change no velocity and no constrained particle (a constrained parent stays where
        // it is), so a projection after them serves the pass before them too.
        const size_t projecting = next == SubFlow::HardWall ? p + 2 : p + 1;
        const SubFlow::Kind projector = projecting < n ? plan.passes[projecting].flows[0].kind : next;
        pass.nextProjectsVelocities = isVelocityFlow(projector) || projector == SubFlow::FilteredKick;
        pass.projectsChordVelocities = isFrozenFlow(next);
        // With constraints a kick is followed by a velocity constraint, so it stays a pass of its own.
        pass.fusedIntoNext = !constrained && pass.flows.size() == 1 && pass.flows[0].kind == SubFlow::Kick &&
                             (next == SubFlow::StiffFlow || next == SubFlow::HarmonicFlow);
    }
    for (size_t after = n; after > 1; --after) {
        FlowPass& pass = plan.passes[after - 2];
        const FlowPass& next = plan.passes[after - 1];
        pass.othersFixedLater =
            !isCoupledFlow(next.flows[0].kind) || (isFrozenFlow(next.flows[0].kind) && next.othersFixedLater);
    }
    return plan;
}

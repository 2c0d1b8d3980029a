#include "FlowExecutors.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

/** The integrated groups of the plan's proposal, or 0 without one. */
int proposalGroups(const StepPlan& plan) {
    for (const FlowPass& pass : plan.passes)
        if (pass.flows[0].kind == SubFlow::ProposalTest)
            return pass.flows[0].groups;
    return 0;
}

} // namespace

vector<bool> ProposalExecutor::energySlots(const StepPlan& plan) {
    // Slots whose groups lie inside what is still uncovered, first come first taken: for a FLAVOR the slot of all
    // groups (its closing kick), for a SIM the soft one.
    int uncovered = proposalGroups(plan);
    vector<bool> withEnergy(plan.slotGroups.size(), false);
    for (size_t s = 0; s < plan.slotGroups.size(); ++s)
        if (uncovered != 0 && (plan.slotGroups[s] & ~uncovered) == 0) {
            withEnergy[s] = true;
            uncovered &= ~plan.slotGroups[s];
        }
    return withEnergy;
}

void ProposalExecutor::prepare(const StepPlan& plan) {
    const vector<bool> withEnergy = energySlots(plan);
    slotsWithEnergy.clear();
    groupsWithoutSlot = proposalGroups(plan);
    for (size_t s = 0; s < withEnergy.size(); ++s)
        if (withEnergy[s]) {
            slotsWithEnergy.push_back((int)s);
            groupsWithoutSlot &= ~plan.slotGroups[s];
        }
    startPositions.resize(parts.particles.numParticles);
    startVelocities.resize(parts.particles.numParticles);
    energyKnown = false;
}

double ProposalExecutor::totalEnergy(ContextImpl& context) {
    double energy = 0.0;
    for (int slot : slotsWithEnergy)
        energy += parts.forces.getEnergy(context, slot);
    if (groupsWithoutSlot != 0)
        energy += parts.forces.evaluateEnergy(context, groupsWithoutSlot);
    return energy;
}

void ProposalExecutor::run(const FlowPass& pass, size_t /*passIndex*/, StepState& state) {
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(state.context.getPlatformData());
    vector<Vec3>& positions = *data.positions;
    vector<Vec3>& velocities = *data.velocities;
    const SubFlow& flow = pass.flows[0];
    if (flow.kind == SubFlow::ProposalStart) {
        if (!energyKnown)
            startPotential = totalEnergy(state.context);
        startKinetic = parts.particles.kineticEnergy(velocities);
        startPositions = positions;
        startVelocities = velocities;
        return;
    }
    const double potential = totalEnergy(state.context);
    const double change = (potential + parts.particles.kineticEnergy(velocities)) - (startPotential + startKinetic);
    const double uniform = parts.random.uniform(state.firstStream + (std::uint64_t)pass.streams[0]);
    // A NaN energy (a proposal that blew up) is rejected.
    const bool accepted = change <= 0.0 || uniform < std::exp(-change / flow.bath.kT);
    counts.proposed++;
    if (accepted) {
        counts.accepted++;
        startPotential = potential;
    } else {
        positions = startPositions;
        for (size_t i = 0; i < velocities.size(); ++i)
            velocities[i] = -startVelocities[i];
        parts.forces.invalidate();
    }
    energyKnown = true;
}

#include "FlowExecutors.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

void ProposalExecutor::prepare(const StepPlan& plan) {
    const vector<bool> withEnergy = MetropolisTest::energySlots(plan);
    slotsWithEnergy.clear();
    for (size_t s = 0; s < withEnergy.size(); ++s)
        if (withEnergy[s])
            slotsWithEnergy.push_back((int)s);
    groupsWithoutSlot = MetropolisTest::groupsWithoutEnergySlot(plan);
    startPositions.resize(parts.particles.numParticles);
    startVelocities.resize(parts.particles.numParticles);
    metropolis.forgetEnergy();
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
        metropolis.start(metropolis.needsStartPotential() ? totalEnergy(state.context) : 0.0,
                         parts.particles.kineticEnergy(velocities));
        startPositions = positions;
        startVelocities = velocities;
        return;
    }
    const double potential = totalEnergy(state.context);
    const double uniform = parts.random.uniform(state.firstStream + (std::uint64_t)pass.streams[0]);
    if (!metropolis.test(potential, parts.particles.kineticEnergy(velocities), uniform, flow.bath.kT)) {
        positions = startPositions;
        for (size_t i = 0; i < velocities.size(); ++i)
            velocities[i] = -startVelocities[i];
        parts.forces.invalidate();
    }
}

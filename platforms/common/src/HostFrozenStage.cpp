#include "HostFrozenStage.h"
#include "openmm/OpenMMException.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

HostFrozenStage::HostFrozenStage(HostStateMirror& state, const ParticleTable& particles)
    : state(state), particles(particles), forceValues(particles.numParticles),
      forcesDownloaded(state.usesDoubles(), particles.numParticles) {}

void HostFrozenStage::setDistances(std::shared_ptr<FrozenDistances> newDistances) {
    distances = std::move(newDistances);
}

void HostFrozenStage::setStiffModes(std::shared_ptr<const StiffModes> newModes) {
    if (newModes != modes)
        modeTask = newModes ? std::make_unique<FrozenFlowTask>(*newModes) : nullptr;
    modes = std::move(newModes);
}

void HostFrozenStage::forgetFactorizations() {
    if (distances)
        distances->forgetFactorizations();
}

void HostFrozenStage::run(const SubFlow& flow, const ComputeArray* forces, double tolerance, bool projectOthers) {
    const bool onDistances = flow.frozen == SubFlow::FrozenSet::Distances;
    if (onDistances ? !distances : !modes)
        throw OpenMMException("HostFrozenStage: a frozen flow on " + std::string(onDistances
                                                                                     ? "distances needs setDistances()"
                                                                                     : "stiff modes needs "
                                                                                       "setStiffModes()"));
    const bool drift = flow.kind == SubFlow::FrozenDrift;
    download(drift ? nullptr : forces);
    vector<Vec3>& positions = state.positions;
    vector<Vec3>& velocities = state.velocities;
    if (onDistances) {
        if (drift)
            distances->drift(positions, velocities, particles.inverseMasses, flow.h, tolerance, projectOthers, loop);
        else
            distances->kick(positions, velocities, forceValues, particles.inverseMasses, flow.h, tolerance,
                            projectOthers, loop);
    } else {
        modeTask->h = flow.h;
        modeTask->source = drift ? velocities.data() : forceValues.data();
        modeTask->target = drift ? positions.data() : velocities.data();
        modeTask->sourceIsForce = !drift;
        loop.run(*modeTask, modes->getNumComponents());
    }
    state.upload(drift, true);
}

void HostFrozenStage::download(const ComputeArray* forces) {
    // One wait for the forces, positions and velocities together.
    state.download(true, true, forces, forces != nullptr ? forcesDownloaded.data() : nullptr);
    // Force slots are already in the System's order.
    if (forces != nullptr)
        forcesDownloaded.toVec3(forceValues);
}

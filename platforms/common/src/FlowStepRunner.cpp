#include "FlowStepRunner.h"
#include "internal/ExactModeFlow.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferenceConstraints.h"
#include "openmm/reference/ReferencePlatform.h"
#include <cmath>
#include <istream>
#include <ostream>
#include <string>
#include <utility>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

ReferencePlatform::PlatformData& platformData(ContextImpl& context) {
    // Both the Reference and the CPU platform keep positions, velocities and forces here.
    return *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
}

} // namespace

FlowStepRunner::FlowStepRunner(const System& system, std::unique_ptr<ParallelLoop> loop)
    : loop(std::move(loop)), numParticles(system.getNumParticles()), hasConstraints(system.getNumConstraints() > 0),
      hasVirtualSites(false), kT(-1.0), friction(-1.0), thermostatsPerStep(0), seed(0), nextStream(0) {
    masses.resize(numParticles);
    inverseMasses.resize(numParticles);
    thermalSpeeds.resize(numParticles);
    coordinateInverseMasses.resize(3 * (size_t)numParticles);
    coordinateMovable.resize(3 * (size_t)numParticles);
    for (int i = 0; i < numParticles; ++i) {
        masses[i] = system.getParticleMass(i);
        inverseMasses[i] = (masses[i] == 0.0 ? 0.0 : 1.0 / masses[i]);
        for (int d = 0; d < 3; ++d) {
            coordinateInverseMasses[3 * i + d] = inverseMasses[i];
            coordinateMovable[3 * i + d] = (masses[i] == 0.0 ? 0.0 : 1.0);
        }
        hasVirtualSites = hasVirtualSites || system.isVirtualSite(i);
    }
    if (hasConstraints)
        previousPositions.resize(numParticles);
    thermostated.assign(numParticles, 1.0);
}

void FlowStepRunner::setFrictionParticles(const vector<int>& particles) {
    if (particles == frictionParticles)
        return;
    frictionParticles = particles;
    thermostated.assign(numParticles, particles.empty() ? 1.0 : 0.0);
    for (int p : particles)
        thermostated[p] = 1.0;
}

void FlowStepRunner::setSchedule(const Schedule& newSchedule, double newKT, double newFriction) {
    if (newSchedule == schedule && newKT == kT && newFriction == friction)
        return;
    schedule = newSchedule;
    kT = newKT;
    friction = newFriction;
    prepare();
}

void FlowStepRunner::setStiffModes(std::shared_ptr<const StiffModes> modes) {
    stiffModes = modes;
    stiffFlowTask = modes ? std::make_unique<StiffFlowTask>(*modes) : nullptr;
    frozenFlowTask = modes ? std::make_unique<FrozenFlowTask>(*modes) : nullptr;
    prepare();
}

void FlowStepRunner::setFrozenDistances(std::shared_ptr<FrozenDistances> distances) {
    frozenDistances = distances;
}

void FlowStepRunner::prepare() {
    plan = compileStepPlan(schedule, hasConstraints);
    if (plan.slotGroups.size() > (size_t)MaxForceSlots)
        throw OpenMMException("FlowStepRunner: a step may kick with at most " + std::to_string(MaxForceSlots) +
                              " distinct force-group sets");
    slots.resize(plan.slotGroups.size());
    for (size_t i = 0; i < slots.size(); ++i) {
        slots[i].groups = plan.slotGroups[i];
        slots[i].valid = false;
        slots[i].forces.resize(numParticles);
    }
    for (int i = 0; i < numParticles; ++i)
        thermalSpeeds[i] = std::sqrt(kT * inverseMasses[i]);
    preparedPasses.clear();
    stiffFlows.assign(plan.passes.size(), StiffModes::Propagator());
    thermostatsPerStep = 0;
    for (size_t passIndex = 0; passIndex < plan.passes.size(); ++passIndex) {
        const FlowPass& pass = plan.passes[passIndex];
        vector<PreparedFlow> prepared;
        for (size_t k = 0; k < pass.flows.size(); ++k) {
            const SubFlow& flow = pass.flows[k];
            PreparedFlow p{flow.kind, flow.h, pass.slots[k], 1.0, 0.0, 0};
            if (flow.kind == SubFlow::Thermostat) {
                const VelocityFlow ou = computeVelocityFlow(friction, flow.h);
                p.decay = ou.decay;
                p.noise = ou.noise;
                p.streamOffset = thermostatsPerStep++;
            }
            if (flow.kind == SubFlow::StiffFlow) {
                p.streamOffset = thermostatsPerStep++;
                if (stiffModes)
                    stiffModes->computePropagator(flow.h, friction, kT, stiffFlows[passIndex]);
            }
            if (flow.kind == SubFlow::HarmonicFlow && stiffModes)
                stiffModes->computePropagator(flow.h, 0.0, kT, stiffFlows[passIndex]);
            prepared.push_back(p);
        }
        preparedPasses.push_back(prepared);
    }
    // With constraints a kick is followed by a velocity constraint, so it stays a pass of its own.
    kickFusedIntoNext.assign(plan.passes.size(), false);
    for (size_t p = 0; p + 1 < plan.passes.size(); ++p)
        kickFusedIntoNext[p] = !hasConstraints && plan.passes[p].flows.size() == 1 &&
                               plan.passes[p].flows[0].kind == SubFlow::Kick &&
                               (plan.passes[p + 1].flows[0].kind == SubFlow::StiffFlow ||
                                plan.passes[p + 1].flows[0].kind == SubFlow::HarmonicFlow);
}

void FlowStepRunner::setRandomSeed(std::uint64_t newSeed) {
    seed = newSeed;
    random = CounterRandom(seed);
    nextStream = 0;
}

void FlowStepRunner::invalidateForces() {
    for (ForceSlot& slot : slots)
        slot.valid = false;
}

void FlowStepRunner::ensureForces(ContextImpl& context, int slotIndex) {
    ForceSlot& slot = slots[slotIndex];
    if (slot.valid)
        return;
    if (hasVirtualSites)
        context.computeVirtualSites();
    context.calcForcesAndEnergy(true, false, slot.groups);
    // Take the platform's force buffer instead of copying it; the platform refills whatever buffer it holds.
    std::swap(*platformData(context).forces, slot.forces);
    slot.valid = true;
}

void FlowStepRunner::step(ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid) {
    ReferencePlatform::PlatformData& data = platformData(context);
    vector<Vec3>& positions = *data.positions;
    vector<Vec3>& velocities = *data.velocities;
    if (!forcesValid)
        invalidateForces();
    const Vec3* kickForces = nullptr;
    double kickStep = 0.0;
    for (size_t p = 0; p < plan.passes.size(); ++p) {
        const vector<PreparedFlow>& flows = preparedPasses[p];
        if (kickFusedIntoNext[p]) {
            ensureForces(context, flows[0].slot);
            kickForces = slots[flows[0].slot].forces.data();
            kickStep = flows[0].h;
            continue;
        }
        if (flows[0].kind == SubFlow::StiffFlow || flows[0].kind == SubFlow::HarmonicFlow) {
            runStiffFlow(context, p, flows[0], constraintTolerance, kickForces, kickStep);
            kickForces = nullptr;
            continue;
        }
        if (flows[0].kind == SubFlow::FrozenDrift || flows[0].kind == SubFlow::FrozenKick) {
            runFrozenFlow(context, flows[0], constraintTolerance);
            continue;
        }
        ParticlePass pass;
        pass.flows = flows.data();
        pass.numFlows = (int)flows.size();
        pass.positions = positions.data();
        pass.velocities = velocities.data();
        pass.coordinateInverseMasses = coordinateInverseMasses.data();
        pass.coordinateMovable = coordinateMovable.data();
        pass.thermostated = thermostated.data();
        pass.thermalSpeeds = thermalSpeeds.data();
        pass.random = &random;
        pass.firstStream = nextStream;
        bool drifts = false;
        double driftTime = 0.0;
        for (const PreparedFlow& flow : flows) {
            if (flow.kind == SubFlow::Kick) {
                ensureForces(context, flow.slot);
                pass.slotForces[flow.slot] = slots[flow.slot].forces.data();
            }
            if (flow.kind == SubFlow::Drift) {
                drifts = true;
                driftTime += flow.h;
            }
        }
        if (hasConstraints && drifts)
            previousPositions = positions;
        loop->run(pass, numParticles);
        if (drifts)
            invalidateForces();
        if (hasConstraints) {
            // With constraints every pass holds one sub-flow (compileStepPlan).
            if (drifts) {
                data.constraints->apply(previousPositions, positions, inverseMasses, constraintTolerance);
                const double inverseTime = 1.0 / driftTime;
                for (int i = 0; i < numParticles; ++i)
                    if (inverseMasses[i] != 0.0)
                        velocities[i] = (positions[i] - previousPositions[i]) * inverseTime;
            } else {
                data.constraints->applyToVelocities(positions, velocities, inverseMasses, constraintTolerance);
            }
        }
    }
    nextStream += thermostatsPerStep;
    if (hasVirtualSites)
        context.computeVirtualSites();
    data.time += stepSize;
    data.stepCount++;
    forcesValid = true;
}

void FlowStepRunner::runStiffFlow(ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                                  double constraintTolerance, const Vec3* kickForces, double kickStep) {
    if (!stiffModes)
        throw OpenMMException("FlowStepRunner: a StiffFlow or HarmonicFlow needs setStiffModes()");
    ReferencePlatform::PlatformData& data = platformData(context);
    vector<Vec3>& positions = *data.positions;
    if (hasConstraints)
        previousPositions = positions;
    StiffFlowTask& task = *stiffFlowTask;
    task.propagator = &stiffFlows[passIndex];
    task.positions = positions.data();
    task.velocities = data.velocities->data();
    task.random = &random;
    task.stream = nextStream + flow.streamOffset;
    task.kickForces = kickForces;
    task.inverseMasses = inverseMasses.data();
    task.kickStep = kickStep;
    loop->run(task, stiffModes->getNumComponents());
    invalidateForces();
    if (hasConstraints) {
        // Only particles outside stiff components may be constrained; they moved by the free flow.
        data.constraints->apply(previousPositions, positions, inverseMasses, constraintTolerance);
        data.constraints->applyToVelocities(positions, *data.velocities, inverseMasses, constraintTolerance);
    }
}

void FlowStepRunner::runFrozenFlow(ContextImpl& context, const PreparedFlow& flow, double constraintTolerance) {
    if (frozenDistances) {
        // The System's constraints are part of the frozen distances' solver.
        ReferencePlatform::PlatformData& data = platformData(context);
        if (flow.kind == SubFlow::FrozenDrift) {
            frozenDistances->drift(*data.positions, *data.velocities, inverseMasses, flow.h, constraintTolerance,
                                   *loop);
            invalidateForces();
        } else {
            ensureForces(context, flow.slot);
            frozenDistances->kick(*data.positions, *data.velocities, slots[flow.slot].forces, inverseMasses, flow.h,
                                  constraintTolerance, *loop);
        }
        return;
    }
    if (!stiffModes)
        throw OpenMMException("FlowStepRunner: a FrozenDrift or FrozenKick needs setStiffModes()");
    ReferencePlatform::PlatformData& data = platformData(context);
    vector<Vec3>& positions = *data.positions;
    vector<Vec3>& velocities = *data.velocities;
    FrozenFlowTask& task = *frozenFlowTask;
    task.h = flow.h;
    if (flow.kind == SubFlow::FrozenDrift) {
        if (hasConstraints)
            previousPositions = positions;
        task.source = velocities.data();
        task.target = positions.data();
        task.sourceIsForce = false;
        loop->run(task, stiffModes->getNumComponents());
        invalidateForces();
        if (hasConstraints) {
            // Constrained particles belong to no stiff component (StiffModesMeasurement): for them this was a plain
            // drift, and their velocities take the constrained displacement as after any drift.  The velocities of
            // stiff particles keep the rates of their frozen coordinates.
            data.constraints->apply(previousPositions, positions, inverseMasses, constraintTolerance);
            const double inverseTime = 1.0 / flow.h;
            for (int i = 0; i < numParticles; ++i)
                if (inverseMasses[i] != 0.0 && !stiffModes->isStiffParticle(i))
                    velocities[i] = (positions[i] - previousPositions[i]) * inverseTime;
        }
    } else {
        ensureForces(context, flow.slot);
        task.source = slots[flow.slot].forces.data();
        task.target = velocities.data();
        task.sourceIsForce = true;
        loop->run(task, stiffModes->getNumComponents());
        if (hasConstraints)
            data.constraints->applyToVelocities(positions, velocities, inverseMasses, constraintTolerance);
    }
}

double FlowStepRunner::kineticEnergy(ContextImpl& context) const {
    const vector<Vec3>& velocities = *platformData(context).velocities;
    double energy = 0.0;
    for (int i = 0; i < numParticles; ++i)
        energy += masses[i] * velocities[i].dot(velocities[i]);
    return 0.5 * energy;
}

void FlowStepRunner::createCheckpoint(std::ostream& stream) const {
    stream.write((const char*)&seed, sizeof(seed));
    stream.write((const char*)&nextStream, sizeof(nextStream));
}

void FlowStepRunner::loadCheckpoint(std::istream& stream) {
    std::uint64_t storedSeed, storedStream;
    stream.read((char*)&storedSeed, sizeof(storedSeed));
    stream.read((char*)&storedStream, sizeof(storedStream));
    setRandomSeed(storedSeed);
    nextStream = storedStream;
    invalidateForces();
}

#include "FlowStepRunner.h"
#include "internal/ExactModeFlow.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferenceConstraints.h"
#include "openmm/reference/ReferencePlatform.h"
#include <algorithm>
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
      hasVirtualSites(false), kT(-1.0), friction(-1.0), stiffKT(-1.0), stiffFriction(-1.0), thermostatsPerStep(0),
      seed(0), nextStream(0) {
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
    if (hasConstraints) {
        previousPositions.resize(numParticles);
        unconstrainedPositions.resize(numParticles);
        constraintSystem = std::make_unique<System>();
        for (int i = 0; i < numParticles; ++i)
            constraintSystem->addParticle(masses[i]);
        for (int c = 0; c < system.getNumConstraints(); ++c) {
            int p1, p2;
            double distance;
            system.getConstraintParameters(c, p1, p2, distance);
            constraintSystem->addConstraint(p1, p2, distance);
        }
        for (int f = 0; f < system.getNumForces(); ++f)
            if (const auto* angles = dynamic_cast<const HarmonicAngleForce*>(&system.getForce(f))) {
                HarmonicAngleForce* copy = new HarmonicAngleForce();
                for (int a = 0; a < angles->getNumAngles(); ++a) {
                    int p1, p2, p3;
                    double angle, k;
                    angles->getAngleParameters(a, p1, p2, p3, angle, k);
                    copy->addAngle(p1, p2, p3, angle, k);
                }
                constraintSystem->addForce(copy);
            }
    }
    thermostated.assign(numParticles, 1.0);
    shareForces.assign(numParticles, Vec3());
    openingForces.assign(numParticles, Vec3());
    forceDifferences.assign(numParticles, Vec3());
}

FlowStepRunner::~FlowStepRunner() = default;

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

void FlowStepRunner::setStiffModeBath(double newKT, double newFriction) {
    if (newKT == stiffKT && newFriction == stiffFriction)
        return;
    stiffKT = newKT;
    stiffFriction = newFriction;
    prepare();
}

void FlowStepRunner::setBiasRemoval(StiffModes::BiasRemoval removal) {
    if (removal == biasRemoval)
        return;
    biasRemoval = removal;
    prepare();
}

void FlowStepRunner::setMiddleZeroModes(bool middle) {
    if (middle == middleZeroModes)
        return;
    middleZeroModes = middle;
    prepare();
}

void FlowStepRunner::setStiffModes(std::shared_ptr<const StiffModes> modes) {
    stiffModes = modes;
    carriedConstraints.reset();
    carriedParticles.clear();
    if (modes && hasConstraints) {
        // The constrained particle of each stiff component (the API checks allow at most one) carries the others.
        vector<int> componentOf(numParticles, -1);
        for (int c = 0; c < modes->getNumComponents(); ++c)
            if (modes->getComponent(c).stiff)
                for (int k = 0; k < modes->getComponent(c).numParticles; ++k)
                    componentOf[modes->getComponentParticles(c)[k]] = c;
        vector<int> carrierOf(modes->getNumComponents(), -1);
        for (int c = 0; c < constraintSystem->getNumConstraints(); ++c) {
            int p1, p2;
            double distance;
            constraintSystem->getConstraintParameters(c, p1, p2, distance);
            for (int p : {p1, p2})
                if (componentOf[p] >= 0)
                    carrierOf[componentOf[p]] = p;
        }
        carriedInverseMasses = inverseMasses;
        for (int c = 0; c < modes->getNumComponents(); ++c) {
            const int carrier = carrierOf[c];
            if (carrier < 0)
                continue;
            double total = 0;
            for (int k = 0; k < modes->getComponent(c).numParticles; ++k) {
                const int p = modes->getComponentParticles(c)[k];
                total += masses[p];
                if (p != carrier)
                    carriedParticles.emplace_back(p, carrier);
            }
            carriedInverseMasses[carrier] = 1.0 / total;
            constraintSystem->setParticleMass(carrier, total);
        }
        if (!carriedParticles.empty())
            carriedConstraints = std::make_unique<ReferenceConstraints>(*constraintSystem);
        for (int i = 0; i < numParticles; ++i)
            constraintSystem->setParticleMass(i, masses[i]);
        carrierBefore.resize(carriedParticles.size());
    }
    carrierImpulses.assign(carriedParticles.size(), Vec3());
    shareParticles.clear();
    for (const auto& pair : carriedParticles)
        for (int p : {pair.first, pair.second})
            if (std::find(shareParticles.begin(), shareParticles.end(), p) == shareParticles.end())
                shareParticles.push_back(p);
    // The modes are measured again after parameter changes and checkpoints: the history of particles that are still
    // carried or stiff stays.
    vector<bool> keepShare(numParticles, false);
    for (int p : shareParticles)
        keepShare[p] = true;
    for (int i = 0; i < numParticles; ++i) {
        if (!keepShare[i])
            shareForces[i] = Vec3();
        if (!modes || !modes->isStiffParticle(i))
            forceDifferences[i] = Vec3();
    }
    stiffFlowTask = modes ? std::make_unique<StiffFlowTask>(*modes) : nullptr;
    forceResponseTask = modes ? std::make_unique<ForceResponseTask>(*modes) : nullptr;
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
    forceResponses.assign(plan.passes.size(), StiffModes::ForceResponse());
    processingResponses.assign(plan.passes.size(), StiffModes::ForceResponse());
    const double modeKT = stiffKT < 0 ? kT : stiffKT, modeFriction = stiffFriction < 0 ? friction : stiffFriction;
    thermostatsPerStep = 0;
    for (size_t passIndex = 0; passIndex < plan.passes.size(); ++passIndex) {
        const FlowPass& pass = plan.passes[passIndex];
        vector<PreparedFlow> prepared;
        for (size_t k = 0; k < pass.flows.size(); ++k) {
            const SubFlow& flow = pass.flows[k];
            PreparedFlow p{flow.kind, flow.h, pass.slots[k], 1.0, 0.0, 0, 0.0, 0.0};
            if (flow.kind == SubFlow::Thermostat) {
                const VelocityFlow ou = computeVelocityFlow(friction, flow.h);
                p.decay = ou.decay;
                p.noise = ou.noise;
                p.streamOffset = thermostatsPerStep++;
            }
            if (flow.kind == SubFlow::StiffFlow || flow.kind == SubFlow::FilteredStiffFlow) {
                p.streamOffset = thermostatsPerStep++;
                // Constrained particles are free particles or carry their component as a rigid body: zero modes.
                const bool filtered = flow.kind == SubFlow::FilteredStiffFlow;
                const bool middle = filtered && middleZeroModes && flow.h > 0;
                const ModeFlow zeroMode = middle ? computeMiddleFreeFlow(friction, flow.h)
                                                 : computeModeFlow(0.0, flow.h > 0 ? friction : 0.0, std::abs(flow.h));
                p.constraintImpulseScale = 1.0 / (flow.h > 0 ? zeroMode.xv : -zeroMode.xv);
                p.constraintVelocityScale = zeroMode.vv * p.constraintImpulseScale;
                const bool warped = filtered && biasRemoval == StiffModes::BiasRemoval::WarpedFlow;
                if (stiffModes)
                    stiffModes->computePropagator(flow.h, friction, kT, modeFriction, modeKT, stiffFlows[passIndex],
                                                  warped, middle);
            }
            if (stiffModes && (flow.kind == SubFlow::FilteredStiffFlow || flow.kind == SubFlow::FilteredKick)) {
                const bool closing = flow.kind == SubFlow::FilteredKick;
                stiffModes->computeForceResponse(flow.h, friction, modeFriction, closing, biasRemoval, middleZeroModes,
                                                 forceResponses[passIndex]);
                stiffModes->computeVelocityProcessing(flow.h, modeFriction, closing, biasRemoval,
                                                      processingResponses[passIndex]);
            }
            if (flow.kind == SubFlow::HarmonicFlow && stiffModes)
                stiffModes->computePropagator(flow.h, 0.0, kT, 0.0, kT, stiffFlows[passIndex]);
            prepared.push_back(p);
        }
        preparedPasses.push_back(prepared);
    }
    // A stiff flow whose next pass is a kick leaves its velocities to that kick's projection: the projection is linear
    // at fixed positions, so projecting once after the kick is the same as before and after it.
    // A drift whose next pass is a frozen flow projects its chord velocities for it (see step()).
    kickProjectsNext.assign(plan.passes.size(), false);
    frozenFlowNext.assign(plan.passes.size(), false);
    for (size_t p = 0; p + 1 < plan.passes.size(); ++p) {
        const SubFlow::Kind next = plan.passes[p + 1].flows[0].kind;
        kickProjectsNext[p] = isVelocityFlow(next) || next == SubFlow::FilteredKick;
        frozenFlowNext[p] = next == SubFlow::FrozenDrift || next == SubFlow::FrozenKick;
    }
    auto particlePass = [&](size_t p) { return !isModeFlow(plan.passes[p].flows[0].kind); };
    otherVelocitiesFixedLater.assign(plan.passes.size(), false);
    for (size_t after = plan.passes.size(); after > 1; --after) {
        const size_t p = after - 2;
        const SubFlow::Kind next = plan.passes[p + 1].flows[0].kind;
        otherVelocitiesFixedLater[p] =
            particlePass(p + 1) ||
            ((next == SubFlow::FrozenDrift || next == SubFlow::FrozenKick) && otherVelocitiesFixedLater[p + 1]);
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
    virtualSitesPlaced = false;
}

void FlowStepRunner::ensureForces(ContextImpl& context, int slotIndex) {
    ForceSlot& slot = slots[slotIndex];
    if (slot.valid)
        return;
    if (hasVirtualSites && !virtualSitesPlaced)
        context.computeVirtualSites();
    virtualSitesPlaced = true;
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
    historyLoaded = false;
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
        // Passes over stiff components or frozen coordinates hold one sub-flow each (compileStepPlan).
        switch (flows[0].kind) {
        case SubFlow::StiffFlow:
        case SubFlow::HarmonicFlow:
            runStiffFlow(context, p, flows[0], constraintTolerance, kickForces, kickStep);
            kickForces = nullptr;
            continue;
        case SubFlow::FilteredStiffFlow:
            // The forces where the flow begins; runStiffFlow adds their response after the flow.
            ensureForces(context, flows[0].slot);
            runStiffFlow(context, p, flows[0], constraintTolerance, nullptr, 0.0);
            continue;
        case SubFlow::FilteredKick:
            runFilteredKick(context, p, flows[0], constraintTolerance);
            continue;
        case SubFlow::FrozenDrift:
        case SubFlow::FrozenKick:
            runFrozenFlow(context, p, flows[0], constraintTolerance);
            continue;
        case SubFlow::Kick:
        case SubFlow::Drift:
        case SubFlow::Thermostat:
            break;
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
            // With constraints a pass is one sub-flow or a run of kicks and thermostats (compileStepPlan).
            for (const PreparedFlow& flow : flows)
                if (flow.kind == SubFlow::Kick)
                    kickConstraintShares(context, flow.h);
            if (drifts) {
                constrainPositions(context, constraintTolerance, 1.0 / driftTime);
                const double inverseTime = 1.0 / driftTime;
                for (int i = 0; i < numParticles; ++i)
                    if (inverseMasses[i] != 0.0)
                        velocities[i] = (positions[i] - previousPositions[i]) * inverseTime;
                // The chord's rates along the constraints are small but not zero; a frozen flow reads the rates of
                // its frozen distances from velocities it takes to satisfy the System's constraints.
                if (frozenFlowNext[p])
                    constrainVelocities(context, constraintTolerance);
            } else {
                constrainVelocities(context, constraintTolerance);
            }
        }
    }
    nextStream += thermostatsPerStep;
    updateConstraintShares(stepSize);
    // Positions that forces were evaluated at already have their virtual sites.
    if (hasVirtualSites && !virtualSitesPlaced)
        context.computeVirtualSites();
    virtualSitesPlaced = true;
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
    if (flow.kind == SubFlow::FilteredStiffFlow) {
        // The slot still holds the forces at the positions before the flow (nothing evaluated them since).
        ForceResponseTask& response = *forceResponseTask;
        response.response = &forceResponses[passIndex];
        response.forces = slots[flow.slot].forces.data();
        response.extraForces = shareParticles.empty() ? nullptr : shareForces.data();
        // It also undoes the velocity processing of the last closing kick, in the flow's image.
        setProcessing(response, passIndex, false);
        response.positions = positions.data();
        response.velocities = data.velocities->data();
        loop->run(response, stiffModes->getNumComponents());
    }
    invalidateForces();
    if (hasConstraints) {
        // Constrained particles of stiff components carry their components (see the class comment).  The correction
        // of the positions is an impulse at the start of the flow (as in RATTLE), so it also changes the velocities:
        // in a zero mode an impulse dv0 moves the position by Phi_xv dv0 and the velocity by Phi_vv dv0.  The
        // projection after it removes what is left along the constraints.
        unconstrainedPositions = positions;
        constrainPositions(context, constraintTolerance, flow.constraintImpulseScale);
        vector<Vec3>& velocities = *data.velocities;
        for (int i = 0; i < numParticles; ++i)
            if (inverseMasses[i] != 0.0)
                velocities[i] += (positions[i] - unconstrainedPositions[i]) * flow.constraintVelocityScale;
        if (!kickProjectsNext[passIndex])
            constrainVelocities(context, constraintTolerance);
    }
}

void FlowStepRunner::runFilteredKick(ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                                     double constraintTolerance) {
    if (!stiffModes)
        throw OpenMMException("FlowStepRunner: a FilteredKick needs setStiffModes()");
    ensureForces(context, flow.slot);
    ReferencePlatform::PlatformData& data = platformData(context);
    ForceResponseTask& response = *forceResponseTask;
    response.response = &forceResponses[passIndex];
    response.forces = slots[flow.slot].forces.data();
    response.extraForces = shareParticles.empty() ? nullptr : shareForces.data();
    // With the velocity processing: beta times the change of the soft force over the step off the stiff modes.
    setProcessing(response, passIndex, true);
    response.positions = data.positions->data();
    response.velocities = data.velocities->data();
    loop->run(response, stiffModes->getNumComponents());
    if (hasConstraints)
        constrainVelocities(context, constraintTolerance);
}

void FlowStepRunner::setProcessing(ForceResponseTask& task, size_t passIndex, bool closing) {
    task.processing = &processingResponses[passIndex];
    task.closing = closing;
    task.openingForces = openingForces.data();
    task.forceChanges = forceDifferences.data();
}

void FlowStepRunner::constrainPositions(ContextImpl& context, double tolerance, double impulsePerCorrection) {
    ReferencePlatform::PlatformData& data = platformData(context);
    vector<Vec3>& positions = *data.positions;
    if (!carriedConstraints) {
        data.constraints->apply(previousPositions, positions, inverseMasses, tolerance);
        return;
    }
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        carrierBefore[k] = positions[carriedParticles[k].second];
    carriedConstraints->apply(previousPositions, positions, carriedInverseMasses, tolerance);
    addCarrierImpulses(positions, impulsePerCorrection);
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        positions[carriedParticles[k].first] += positions[carriedParticles[k].second] - carrierBefore[k];
}

void FlowStepRunner::constrainVelocities(ContextImpl& context, double tolerance) {
    ReferencePlatform::PlatformData& data = platformData(context);
    vector<Vec3>& velocities = *data.velocities;
    if (!carriedConstraints) {
        data.constraints->applyToVelocities(*data.positions, velocities, inverseMasses, tolerance);
        return;
    }
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        carrierBefore[k] = velocities[carriedParticles[k].second];
    carriedConstraints->applyToVelocities(*data.positions, velocities, carriedInverseMasses, tolerance);
    addCarrierImpulses(velocities, 1.0);
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        velocities[carriedParticles[k].first] += velocities[carriedParticles[k].second] - carrierBefore[k];
}

void FlowStepRunner::addCarrierImpulses(const vector<Vec3>& corrected, double impulsePerCorrection) {
    for (size_t k = 0; k < carriedParticles.size(); ++k) {
        const int carrier = carriedParticles[k].second;
        carrierImpulses[k] +=
            (corrected[carrier] - carrierBefore[k]) * (impulsePerCorrection / carriedInverseMasses[carrier]);
    }
}

void FlowStepRunner::updateConstraintShares(double stepSize) {
    if (carriedParticles.empty())
        return;
    // The carrier's mean constraint force over the step is J / stepSize; carrying gave the carried particle the
    // share m_p / M of it, which the true dynamics gives the carrier.
    for (int p : shareParticles)
        shareForces[p] = Vec3();
    for (size_t k = 0; k < carriedParticles.size(); ++k) {
        const int carried = carriedParticles[k].first, carrier = carriedParticles[k].second;
        const Vec3 share = carrierImpulses[k] * (-masses[carried] * carriedInverseMasses[carrier] / stepSize);
        shareForces[carried] += share;
        shareForces[carrier] -= share;
        carrierImpulses[k] = Vec3();
    }
}

void FlowStepRunner::forgetStepHistory() {
    // OpenMM announces the positions and velocities of a checkpoint after the integrator has read its part.
    if (historyLoaded)
        return;
    std::fill(shareForces.begin(), shareForces.end(), Vec3());
    std::fill(forceDifferences.begin(), forceDifferences.end(), Vec3());
}

void FlowStepRunner::kickConstraintShares(ContextImpl& context, double h) {
    vector<Vec3>& velocities = *platformData(context).velocities;
    for (int p : shareParticles)
        velocities[p] += shareForces[p] * (h * inverseMasses[p]);
}

void FlowStepRunner::runFrozenFlow(ContextImpl& context, size_t passIndex, const PreparedFlow& flow,
                                   double constraintTolerance) {
    if (frozenDistances) {
        // The System's constraints are part of the frozen distances' solver.
        ReferencePlatform::PlatformData& data = platformData(context);
        const bool projectOthers = !otherVelocitiesFixedLater[passIndex];
        if (flow.kind == SubFlow::FrozenDrift) {
            frozenDistances->drift(*data.positions, *data.velocities, inverseMasses, flow.h, constraintTolerance,
                                   projectOthers, *loop);
            invalidateForces();
        } else {
            ensureForces(context, flow.slot);
            frozenDistances->kick(*data.positions, *data.velocities, slots[flow.slot].forces, inverseMasses, flow.h,
                                  constraintTolerance, projectOthers, *loop);
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

namespace {

// The integrator's part of a checkpoint: Tag, the integrator's name (length, then characters), the format version,
// the seed and the stream counter, (version 2) the number of carried pairs and their constraint shares, EndTag.
// Version 1 checkpoints (no shares) still load, with zero shares.
const char CheckpointTag[] = "openmm-flavors integrator state\n";
const char CheckpointEndTag[] = "end of openmm-flavors integrator state\n";
const std::uint32_t CheckpointVersion = 2;
const std::uint32_t MaxNameLength = 64;

template <class T> bool readValue(std::istream& stream, T& value) {
    stream.read(reinterpret_cast<char*>(&value), sizeof(T));
    return stream.gcount() == (std::streamsize)sizeof(T);
}

bool readBytes(std::istream& stream, std::string& text, size_t length) {
    text.assign(length, '\0');
    if (length == 0)
        return true;
    stream.read(&text[0], (std::streamsize)length);
    return stream.gcount() == (std::streamsize)length;
}

// A per-particle history vector as its count of nonzero entries, then (index, x, y, z) for each.
void writeHistory(std::ostream& stream, const vector<Vec3>& values) {
    std::uint32_t count = 0;
    for (const Vec3& value : values)
        count += (value != Vec3());
    stream.write((const char*)&count, sizeof(count));
    for (size_t i = 0; i < values.size(); ++i) {
        if (values[i] == Vec3())
            continue;
        const std::int32_t particle = (std::int32_t)i;
        stream.write((const char*)&particle, sizeof(particle));
        for (int d = 0; d < 3; ++d) {
            const double component = values[i][d];
            stream.write((const char*)&component, sizeof(component));
        }
    }
}

bool readHistory(std::istream& stream, int numParticles, vector<std::pair<int, Vec3>>& entries) {
    std::uint32_t count = 0;
    if (!readValue(stream, count) || count > (std::uint32_t)numParticles)
        return false;
    entries.resize(count);
    for (auto& entry : entries) {
        std::int32_t particle = -1;
        if (!readValue(stream, particle) || particle < 0 || particle >= numParticles)
            return false;
        entry.first = particle;
        for (int d = 0; d < 3; ++d)
            if (!readValue(stream, entry.second[d]))
                return false;
    }
    return true;
}

} // namespace

void FlowStepRunner::createCheckpoint(std::ostream& stream, const std::string& integratorName) const {
    const std::uint32_t nameLength = (std::uint32_t)integratorName.size();
    stream.write(CheckpointTag, sizeof(CheckpointTag) - 1);
    stream.write((const char*)&nameLength, sizeof(nameLength));
    stream.write(integratorName.data(), nameLength);
    stream.write((const char*)&CheckpointVersion, sizeof(CheckpointVersion));
    stream.write((const char*)&seed, sizeof(seed));
    stream.write((const char*)&nextStream, sizeof(nextStream));
    writeHistory(stream, shareForces);
    writeHistory(stream, forceDifferences);
    stream.write(CheckpointEndTag, sizeof(CheckpointEndTag) - 1);
}

void FlowStepRunner::loadCheckpoint(ContextImpl& context, std::istream& stream, const std::string& integratorName) {
    std::string problem;
    std::string tag, name, endTag;
    std::uint32_t nameLength = 0, version = 0;
    std::uint64_t storedSeed = 0, storedStream = 0;
    vector<std::pair<int, Vec3>> storedShares, storedDifferences;
    const bool hasTag = readBytes(stream, tag, sizeof(CheckpointTag) - 1);
    if (!hasTag && stream.gcount() == 0)
        problem = "it holds no data of this integrator (it was made with another integrator, e.g. OpenMM's "
                  "VerletIntegrator, or it is truncated)";
    else if (!hasTag || tag != std::string(CheckpointTag, sizeof(CheckpointTag) - 1))
        problem = "its integrator part is not openmm-flavors data (it was made with another integrator, or it is "
                  "truncated or corrupt)";
    else if (!readValue(stream, nameLength) || nameLength > MaxNameLength || !readBytes(stream, name, nameLength))
        problem = "it is truncated or corrupt (the integrator's name is incomplete)";
    else if (name != integratorName)
        problem = "it was made with " + name;
    else if (!readValue(stream, version))
        problem = "it is truncated (no format version)";
    else if (version != 1 && version != CheckpointVersion)
        problem = "it has format version " + std::to_string(version) + "; this build reads versions 1 to " +
                  std::to_string(CheckpointVersion);
    else if (!readValue(stream, storedSeed) || !readValue(stream, storedStream))
        problem = "it is truncated (the random streams are incomplete)";
    else if (version >= 2 && (!readHistory(stream, numParticles, storedShares) ||
                              !readHistory(stream, numParticles, storedDifferences)))
        problem = "it is truncated or corrupt (the step history (constraint shares and force differences) is "
                  "incomplete or names particles this System does not have)";
    else if (!readBytes(stream, endTag, sizeof(CheckpointEndTag) - 1))
        problem = "it is truncated (no end tag)";
    else if (endTag != std::string(CheckpointEndTag, sizeof(CheckpointEndTag) - 1))
        problem = "it is corrupt (no end tag after the random streams)";
    if (!problem.empty()) {
        restoreContextState(context);
        throw OpenMMException(integratorName + ": loadCheckpoint: the checkpoint is not one of a " + integratorName +
                              ": " + problem +
                              ".  The Context keeps its positions, velocities, box, time, step count, parameters "
                              "and random streams");
    }
    setRandomSeed(storedSeed);
    nextStream = storedStream;
    historyLoaded = false;
    forgetStepHistory();
    historyLoaded = true;
    for (const auto& entry : storedShares)
        shareForces[entry.first] = entry.second;
    for (const auto& entry : storedDifferences)
        forceDifferences[entry.first] = entry.second;
    invalidateForces();
}

void FlowStepRunner::saveContextState(ContextImpl& context, bool withParameters) {
    ReferencePlatform::PlatformData& data = platformData(context);
    saved.positions = *data.positions;
    saved.velocities = *data.velocities;
    saved.boxSize = *data.periodicBoxSize;
    for (int i = 0; i < 3; ++i)
        saved.boxVectors[i] = data.periodicBoxVectors[i];
    saved.time = data.time;
    saved.stepCount = data.stepCount;
    if (withParameters || !saved.valid)
        saved.parameters = context.getParameters();
    saved.valid = true;
}

void FlowStepRunner::restoreContextState(ContextImpl& context) {
    if (!saved.valid)
        return;
    ReferencePlatform::PlatformData& data = platformData(context);
    *data.positions = saved.positions;
    *data.velocities = saved.velocities;
    *data.periodicBoxSize = saved.boxSize;
    for (int i = 0; i < 3; ++i)
        data.periodicBoxVectors[i] = saved.boxVectors[i];
    data.time = saved.time;
    data.stepCount = saved.stepCount;
    // setParameter() notifies the integrator, which saves the state again: iterate over a copy.
    const std::map<std::string, double> parameters = saved.parameters;
    for (const auto& parameter : parameters) {
        const std::map<std::string, double>& current = context.getParameters();
        auto found = current.find(parameter.first);
        if (found != current.end() && found->second != parameter.second)
            context.setParameter(parameter.first, parameter.second);
    }
    invalidateForces();
}

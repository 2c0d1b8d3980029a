#include "FlowExecutors.h"
#include "internal/ExactModeFlow.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

ParticlePassExecutor::ParticlePassExecutor(EngineParts& parts)
    : FlowExecutor(parts), thermalSpeeds(parts.particles.numParticles),
      thermostated(parts.particles.numParticles, 1.0) {}

void ParticlePassExecutor::setFrictionParticles(const vector<int>& particles) {
    if (particles == frictionParticles)
        return;
    frictionParticles = particles;
    thermostated.assign(parts.particles.numParticles, particles.empty() ? 1.0 : 0.0);
    for (int p : particles)
        thermostated[p] = 1.0;
}

void ParticlePassExecutor::prepare(const StepPlan& plan) {
    prepared.assign(plan.passes.size(), {});
    bool haveBath = false;
    Bath bath;
    for (size_t p = 0; p < plan.passes.size(); ++p) {
        const FlowPass& pass = plan.passes[p];
        if (isCoupledFlow(pass.flows[0].kind))
            continue;
        for (size_t k = 0; k < pass.flows.size(); ++k) {
            const SubFlow& flow = pass.flows[k];
            PreparedFlow prepared1{flow.kind, flow.h, pass.slots[k], 1.0, 0.0, pass.streams[k]};
            if (flow.kind == SubFlow::Thermostat) {
                // The thermal speeds are per particle: one temperature for all of a step's thermostats.
                if (haveBath && flow.bath.kT != bath.kT)
                    throw OpenMMException("FlowStepRunner: the thermostats of one step must share one temperature");
                haveBath = true;
                bath = flow.bath;
                const VelocityFlow ou = computeVelocityFlow(flow.bath.friction, flow.h);
                prepared1.decay = ou.decay;
                prepared1.noise = ou.noise;
            }
            prepared[p].push_back(prepared1);
        }
    }
    for (int i = 0; i < parts.particles.numParticles; ++i)
        thermalSpeeds[i] = std::sqrt(bath.kT * parts.particles.inverseMasses[i]);
}

void ParticlePassExecutor::run(const FlowPass& flowPass, size_t passIndex, StepState& state) {
    const vector<PreparedFlow>& flows = prepared[passIndex];
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(state.context.getPlatformData());
    vector<Vec3>& positions = *data.positions;
    vector<Vec3>& velocities = *data.velocities;
    const ParticleTable& particles = parts.particles;
    ParticlePass pass;
    pass.flows = flows.data();
    pass.numFlows = (int)flows.size();
    pass.positions = positions.data();
    pass.velocities = velocities.data();
    pass.coordinateInverseMasses = particles.coordinateInverseMasses.data();
    pass.coordinateMovable = particles.coordinateMovable.data();
    pass.thermostated = thermostated.data();
    pass.thermalSpeeds = thermalSpeeds.data();
    pass.random = &parts.random;
    pass.firstStream = state.firstStream;
    bool drifts = false;
    double driftTime = 0.0;
    for (size_t k = 0; k < flows.size(); ++k) {
        const PreparedFlow& flow = flows[k];
        const SubFlow& setting = flowPass.flows[k];
        if (flow.kind == SubFlow::Kick)
            pass.slotForces[flow.slot] =
                parts.forces.get(state.context, flow.slot, setting.clocked, state.stiffClock + setting.clock).data();
        if (flow.kind == SubFlow::Drift) {
            drifts = true;
            driftTime += flow.h;
        }
    }
    ConstraintProjector* constraints = parts.constraints;
    if (constraints && drifts)
        constraints->rememberPositions(positions);
    parts.loop.run(pass, particles.numParticles);
    if (drifts)
        parts.forces.invalidate();
    if (!constraints)
        return;
    // With constraints a pass is one sub-flow or a run of kicks and thermostats (analyzeStep).
    if (drifts) {
        constraints->constrainPositions(state.context, state.constraintTolerance);
        const double inverseTime = 1.0 / driftTime;
        const vector<Vec3>& before = constraints->getReferencePositions();
        for (int i = 0; i < particles.numParticles; ++i)
            if (particles.inverseMasses[i] != 0.0)
                velocities[i] = (positions[i] - before[i]) * inverseTime;
        // The chord's rates along the constraints are small but not zero; a frozen flow reads the rates of its frozen
        // distances from velocities it takes to satisfy the System's constraints.
        if (flowPass.projectsChordVelocities)
            constraints->constrainVelocities(state.context, state.constraintTolerance);
    } else {
        constraints->constrainVelocities(state.context, state.constraintTolerance);
    }
}

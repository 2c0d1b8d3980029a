#include "FlowStepRunner.h"
#include "FlowCheckpoint.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"
#include <istream>
#include <ostream>
#include <string>
#include <utility>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

FlowStepRunner::FlowStepRunner(const System& system, std::unique_ptr<ParallelLoop> loop)
    : loop(std::move(loop)), particles(system), forces(particles.hasVirtualSites),
      constraints(particles.hasConstraints ? std::make_unique<ConstraintProjector>(system, particles) : nullptr),
      history(particles.numParticles), parts{particles, *this->loop, forces,  constraints.get(),
                                             history,   random,      nullptr, nullptr},
      particlePasses(parts), stiffFlows(parts), frozenFlows(parts), proposals(parts), hardWall(parts) {}

FlowStepRunner::~FlowStepRunner() = default;

FlowExecutor& FlowStepRunner::executorFor(SubFlow::Kind kind) {
    switch (kind) {
    case SubFlow::Kick:
    case SubFlow::Drift:
    case SubFlow::Thermostat:
        return particlePasses;
    case SubFlow::StiffFlow:
    case SubFlow::HarmonicFlow:
    case SubFlow::FilteredStiffFlow:
    case SubFlow::FilteredKick:
        return stiffFlows;
    case SubFlow::FrozenDrift:
    case SubFlow::FrozenKick:
        return frozenFlows;
    case SubFlow::ProposalStart:
    case SubFlow::ProposalTest:
        return proposals;
    case SubFlow::HardWall:
    case SubFlow::HardWallSpeed:
        return hardWall;
    }
    throw OpenMMException("FlowStepRunner: unknown sub-flow kind " + std::to_string((int)kind));
}

void FlowStepRunner::setFrictionParticles(const vector<int>& frictionParticles) {
    particlePasses.setFrictionParticles(frictionParticles);
}

void FlowStepRunner::setSchedule(const Schedule& newSchedule) {
    if (newSchedule == schedule && !plan.passes.empty())
        return;
    schedule = newSchedule;
    prepare();
}

void FlowStepRunner::setStiffModes(std::shared_ptr<const StiffModes> modes) {
    parts.modes = modes;
    if (constraints)
        constraints->setStiffModes(modes.get());
    // The modes are measured again after parameter changes and checkpoints: the history of particles that are still
    // stiff stays.
    history.keepOnly(modes.get());
    prepare();
}

void FlowStepRunner::setFrozenCoordinates(std::shared_ptr<const StiffModes> frozenModes,
                                          std::shared_ptr<FrozenDistances> distances) {
    if (frozenModes)
        setStiffModes(std::move(frozenModes));
    setFrozenDistances(std::move(distances));
}

void FlowStepRunner::setFrozenDistances(std::shared_ptr<FrozenDistances> distances) {
    parts.distances = distances;
}

void FlowStepRunner::prepare() {
    plan = analyzeStep(schedule, particles.hasConstraints);
    if (plan.slotGroups.size() > (size_t)MaxForceSlots)
        throw OpenMMException("FlowStepRunner: a step may kick with at most " + std::to_string(MaxForceSlots) +
                              " distinct force-group sets");
    forces.setSlots(plan.slotGroups, particles.numParticles, MetropolisTest::energySlots(plan));
    for (FlowExecutor* executor : {(FlowExecutor*)&particlePasses, (FlowExecutor*)&stiffFlows,
                                   (FlowExecutor*)&frozenFlows, (FlowExecutor*)&proposals, (FlowExecutor*)&hardWall})
        executor->prepare(plan);
    passExecutors.clear();
    for (const FlowPass& pass : plan.passes)
        passExecutors.push_back(&executorFor(pass.flows[0].kind));
}

void FlowStepRunner::setStiffClock(const std::string& parameter, double microStep, double mesoStep) {
    forces.setClockParameter(parameter);
    stiffClock.configure(parameter, microStep, mesoStep);
}

void FlowStepRunner::setRandomSeed(std::uint64_t newSeed) {
    seed = newSeed;
    random = CounterRandom(seed);
    nextStream = 0;
}

void FlowStepRunner::step(ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid) {
    if (!forcesValid) {
        forces.invalidate();
        proposals.forgetEnergy();
    }
    history.stepStarted();
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
    if (constraints) {
        constraints->startStep();
        constraints->takeOffProcessing(*data.velocities, history.constraintProcessing);
    }
    StepState state{context, constraintTolerance, nextStream};
    state.stiffClock = stiffClock.startStep(data.time);
    for (size_t p = 0; p < plan.passes.size(); ++p) {
        const FlowPass& pass = plan.passes[p];
        if (pass.fusedIntoNext) {
            state.fusedKickForces =
                forces.get(context, pass.slots[0], pass.flows[0].clocked, state.stiffClock + pass.flows[0].clock)
                    .data();
            state.fusedKickStep = pass.flows[0].h;
            continue;
        }
        passExecutors[p]->run(pass, p, state);
    }
    nextStream += plan.noiseStreams;
    // Positions that forces were evaluated at already have their virtual sites.
    forces.placeVirtualSites(context);
    data.time += stepSize;
    data.stepCount++;
    stiffClock.endStep(data.time);
    forcesValid = true;
}

double FlowStepRunner::kineticEnergy(ContextImpl& context) const {
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
    return particles.kineticEnergy(*data.velocities);
}

void FlowStepRunner::forgetStepHistory() {
    history.forget();
    // A cached factorization from where the Context was before would steer the next solves (their refinement starts
    // from it): a state set from outside continues as a new Context would.
    if (parts.distances)
        parts.distances->forgetFactorizations();
}

void FlowStepRunner::saveContextState(ContextImpl& context, bool withParameters) {
    rollback.save(context, withParameters);
}

void FlowStepRunner::createCheckpoint(std::ostream& stream, const std::string& integratorName) const {
    writeFlowCheckpoint(stream, integratorName, seed, nextStream, history, stiffClock.getState(),
                        proposals.getCounts());
}

void FlowStepRunner::loadCheckpoint(ContextImpl& context, std::istream& stream, const std::string& integratorName) {
    std::uint64_t storedSeed = 0, storedStream = 0;
    StepHistory::Stored storedHistory;
    StiffClockState storedClock;
    ProposalCounts storedCounts;
    const std::string problem = readFlowCheckpoint(stream, integratorName, history, storedSeed, storedStream,
                                                   storedHistory, &storedClock, &storedCounts);
    if (!problem.empty()) {
        rollback.restore(context);
        forces.invalidate();
        throw OpenMMException(flowCheckpointError(integratorName, problem));
    }
    setRandomSeed(storedSeed);
    nextStream = storedStream;
    stiffClock.setState(storedClock);
    proposals.setCounts(storedCounts);
    proposals.forgetEnergy();
    history.load(storedHistory);
    if (parts.distances)
        parts.distances->forgetFactorizations();
    forces.invalidate();
}

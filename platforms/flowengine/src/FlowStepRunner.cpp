#include "FlowStepRunner.h"
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
      particlePasses(parts), stiffFlows(parts), frozenFlows(parts) {}

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
    // carried or stiff stays.
    history.keepOnly(constraints ? constraints->getShareParticles() : vector<int>(), modes.get());
    prepare();
}

void FlowStepRunner::setFrozenDistances(std::shared_ptr<FrozenDistances> distances) {
    parts.distances = distances;
}

void FlowStepRunner::prepare() {
    plan = analyzeStep(schedule, particles.hasConstraints);
    if (plan.slotGroups.size() > (size_t)MaxForceSlots)
        throw OpenMMException("FlowStepRunner: a step may kick with at most " + std::to_string(MaxForceSlots) +
                              " distinct force-group sets");
    forces.setSlots(plan.slotGroups, particles.numParticles);
    for (FlowExecutor* executor :
         {(FlowExecutor*)&particlePasses, (FlowExecutor*)&stiffFlows, (FlowExecutor*)&frozenFlows})
        executor->prepare(plan);
    passExecutors.clear();
    for (const FlowPass& pass : plan.passes)
        passExecutors.push_back(&executorFor(pass.flows[0].kind));
}

void FlowStepRunner::setRandomSeed(std::uint64_t newSeed) {
    seed = newSeed;
    random = CounterRandom(seed);
    nextStream = 0;
}

void FlowStepRunner::step(ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid) {
    if (!forcesValid)
        forces.invalidate();
    history.stepStarted();
    StepState state{context, constraintTolerance, nextStream};
    for (size_t p = 0; p < plan.passes.size(); ++p) {
        const FlowPass& pass = plan.passes[p];
        if (pass.fusedIntoNext) {
            state.fusedKickForces = forces.get(context, pass.slots[0]).data();
            state.fusedKickStep = pass.flows[0].h;
            continue;
        }
        passExecutors[p]->run(pass, p, state);
    }
    nextStream += plan.noiseStreams;
    if (constraints)
        constraints->takeShares(stepSize, history.shareForces);
    // Positions that forces were evaluated at already have their virtual sites.
    forces.placeVirtualSites(context);
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
    data.time += stepSize;
    data.stepCount++;
    forcesValid = true;
}

double FlowStepRunner::kineticEnergy(ContextImpl& context) const {
    auto& data = *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
    const vector<Vec3>& velocities = *data.velocities;
    double energy = 0.0;
    for (int i = 0; i < particles.numParticles; ++i)
        energy += particles.masses[i] * velocities[i].dot(velocities[i]);
    return 0.5 * energy;
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

namespace {

// The integrator's part of a checkpoint: Tag, the integrator's name (length, then characters), the format version,
// the seed and the stream counter, (version 2) the step history (StepHistory::write), EndTag.  Version 1 checkpoints
// (no history) still load, with an empty history.
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

} // namespace

void FlowStepRunner::createCheckpoint(std::ostream& stream, const std::string& integratorName) const {
    const std::uint32_t nameLength = (std::uint32_t)integratorName.size();
    stream.write(CheckpointTag, sizeof(CheckpointTag) - 1);
    stream.write((const char*)&nameLength, sizeof(nameLength));
    stream.write(integratorName.data(), nameLength);
    stream.write((const char*)&CheckpointVersion, sizeof(CheckpointVersion));
    stream.write((const char*)&seed, sizeof(seed));
    stream.write((const char*)&nextStream, sizeof(nextStream));
    history.write(stream);
    stream.write(CheckpointEndTag, sizeof(CheckpointEndTag) - 1);
}

void FlowStepRunner::loadCheckpoint(ContextImpl& context, std::istream& stream, const std::string& integratorName) {
    std::string problem;
    std::string tag, name, endTag;
    std::uint32_t nameLength = 0, version = 0;
    std::uint64_t storedSeed = 0, storedStream = 0;
    StepHistory::Stored storedHistory;
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
    else if (version >= 2 && !history.read(stream, storedHistory))
        problem = "it is truncated or corrupt (the step history (constraint shares and force differences) is "
                  "incomplete or names particles this System does not have)";
    else if (!readBytes(stream, endTag, sizeof(CheckpointEndTag) - 1))
        problem = "it is truncated (no end tag)";
    else if (endTag != std::string(CheckpointEndTag, sizeof(CheckpointEndTag) - 1))
        problem = "it is corrupt (no end tag after the random streams)";
    if (!problem.empty()) {
        rollback.restore(context);
        forces.invalidate();
        throw OpenMMException(integratorName + ": loadCheckpoint: the checkpoint is not one of a " + integratorName +
                              ": " + problem +
                              ".  The Context keeps its positions, velocities, box, time, step count, parameters "
                              "and random streams");
    }
    setRandomSeed(storedSeed);
    nextStream = storedStream;
    history.load(storedHistory);
    if (parts.distances)
        parts.distances->forgetFactorizations();
    forces.invalidate();
}

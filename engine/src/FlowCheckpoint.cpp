#include "FlowCheckpoint.h"
#include <istream>
#include <ostream>

using namespace FlavorPlugin;

namespace {

// The integrator's part of a checkpoint: Tag, the integrator's name (length, then characters), the format version,
// the seed and the stream counter, (version 2) the step history (StepHistory::write), (version 3) the stiff clock
// and the time at which it holds, (version 4) the proposal counts, EndTag.  Version 1 checkpoints (no history) still
// load, with an empty history; versions 1 and 2 with a stiff clock that starts afresh; versions 1 to 3 with no
// proposals counted; versions 2 to 4 (whose history is the constraint share forces of an older treatment of
// constrained stiff components, skipped, and the force differences) with no constraint processing.
const char CheckpointTag[] = "openmm-flavors integrator state\n";
const char CheckpointEndTag[] = "end of openmm-flavors integrator state\n";
const std::uint32_t CheckpointVersion = 5;
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

void FlavorPlugin::writeFlowCheckpoint(std::ostream& stream, const std::string& integratorName, std::uint64_t seed,
                                       std::uint64_t nextStream, const StepHistory& history,
                                       const StiffClockState& clock, const ProposalCounts& counts) {
    const std::uint32_t nameLength = (std::uint32_t)integratorName.size();
    stream.write(CheckpointTag, sizeof(CheckpointTag) - 1);
    stream.write((const char*)&nameLength, sizeof(nameLength));
    stream.write(integratorName.data(), nameLength);
    stream.write((const char*)&CheckpointVersion, sizeof(CheckpointVersion));
    stream.write((const char*)&seed, sizeof(seed));
    stream.write((const char*)&nextStream, sizeof(nextStream));
    history.write(stream);
    stream.write((const char*)&clock.clock, sizeof(clock.clock));
    stream.write((const char*)&clock.time, sizeof(clock.time));
    stream.write((const char*)&counts.proposed, sizeof(counts.proposed));
    stream.write((const char*)&counts.accepted, sizeof(counts.accepted));
    stream.write(CheckpointEndTag, sizeof(CheckpointEndTag) - 1);
}

std::string FlavorPlugin::readFlowCheckpoint(std::istream& stream, const std::string& integratorName,
                                             const StepHistory& history, std::uint64_t& storedSeed,
                                             std::uint64_t& storedStream, StepHistory::Stored& storedHistory,
                                             StiffClockState* clock, ProposalCounts* counts) {
    std::string problem;
    StiffClockState storedClock;
    ProposalCounts storedCounts;
    std::string tag, name, endTag;
    std::uint32_t nameLength = 0, version = 0;
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
    else if (version < 1 || version > CheckpointVersion)
        problem = "it has format version " + std::to_string(version) + "; this build reads versions 1 to " +
                  std::to_string(CheckpointVersion);
    else if (!readValue(stream, storedSeed) || !readValue(stream, storedStream))
        problem = "it is truncated (the random streams are incomplete)";
    else if (version >= 2 && !history.read(stream, storedHistory, version < 5))
        problem = "it is truncated or corrupt (the step history (force differences and constraint processing) is "
                  "incomplete or names particles this System does not have)";
    else if (version >= 3 && (!readValue(stream, storedClock.clock) || !readValue(stream, storedClock.time)))
        problem = "it is truncated (the stiff clock is incomplete)";
    else if (version >= 4 && (!readValue(stream, storedCounts.proposed) || !readValue(stream, storedCounts.accepted) ||
                              storedCounts.accepted > storedCounts.proposed))
        problem = "it is truncated or corrupt (the Metropolis proposal counts are incomplete)";
    else if (!readBytes(stream, endTag, sizeof(CheckpointEndTag) - 1))
        problem = "it is truncated (no end tag)";
    else if (endTag != std::string(CheckpointEndTag, sizeof(CheckpointEndTag) - 1))
        problem = "it is corrupt (no end tag after the random streams)";
    if (problem.empty() && clock != nullptr)
        *clock = storedClock;
    if (problem.empty() && counts != nullptr)
        *counts = storedCounts;
    return problem;
}

std::string FlavorPlugin::flowCheckpointError(const std::string& integratorName, const std::string& problem) {
    return integratorName + ": loadCheckpoint: the checkpoint is not one of a " + integratorName + ": " + problem +
           ".  The Context keeps its positions, velocities, box, time, step count, parameters and random streams";
}

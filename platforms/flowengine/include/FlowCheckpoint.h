#ifndef OPENMM_FLAVORS_FLOW_CHECKPOINT_H_
#define OPENMM_FLAVORS_FLOW_CHECKPOINT_H_

#include "StepHistory.h"
#include "internal/windowsExportFlavors.h"
#include <cstdint>
#include <iosfwd>
#include <string>

namespace FlavorPlugin {

/**
 * The integrator's part of a checkpoint, the same on every platform: a tag, the integrator's name (length, then
 * characters), the format version, the seed and the stream counter of the random streams, (version 2) the step
 * history (StepHistory::write), an end tag.  Version 1 checkpoints (no history) still load, with an empty history.
 */
OPENMM_EXPORT_FLAVORS void writeFlowCheckpoint(std::ostream& stream, const std::string& integratorName,
                                               std::uint64_t seed, std::uint64_t nextStream,
                                               const StepHistory& history);

/**
 * Reads what writeFlowCheckpoint() wrote for integratorName into seed, nextStream and stored (checked against
 * history's number of particles).  Returns an empty string, or what the stream holds instead (another integrator's
 * data, another format version, a truncated or corrupt one), for flowCheckpointError().
 */
OPENMM_EXPORT_FLAVORS std::string readFlowCheckpoint(std::istream& stream, const std::string& integratorName,
                                                     const StepHistory& history, std::uint64_t& seed,
                                                     std::uint64_t& nextStream, StepHistory::Stored& stored);

/** The message of a failed load: what the stream holds and that the Context keeps its state. */
OPENMM_EXPORT_FLAVORS std::string flowCheckpointError(const std::string& integratorName, const std::string& problem);

} // namespace FlavorPlugin

#endif

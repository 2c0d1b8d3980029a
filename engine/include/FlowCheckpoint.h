#ifndef OPENMM_FLAVORS_FLOW_CHECKPOINT_H_
#define OPENMM_FLAVORS_FLOW_CHECKPOINT_H_

#include "StepHistory.h"
#include "internal/windowsExportFlavors.h"
#include <cstdint>
#include <iosfwd>
#include <limits>
#include <string>

namespace FlavorPlugin {

/**
 * The stiff clock of a FlavorIntegrator (setStiffClockParameter): its value where the next step starts (ps) and the
 * Context's time at which it holds; time NaN means it starts afresh from the Context's time times tau/delta.
 */
struct StiffClockState {
    double clock = 0.0;
    double time = std::numeric_limits<double>::quiet_NaN();
};

/** The Metropolis-adjusted steps' proposals since the Context was created: how many, and how many were accepted. */
struct ProposalCounts {
    std::uint64_t proposed = 0, accepted = 0;
};

/**
 * The integrator's part of a checkpoint, the same on every platform: a tag, the integrator's name (length, then
 * characters), the format version, the seed and the stream counter of the random streams, (version 2) the step
 * history (StepHistory::write), (version 3) the stiff clock, (version 4) the proposal counts, an end tag.  Version 1
 * checkpoints (no history) still load, with an empty history; versions 1 and 2 (no stiff clock) with a clock that
 * starts afresh; versions 1 to 3 with no proposals counted.
 */
OPENMM_EXPORT_FLAVORS void writeFlowCheckpoint(std::ostream& stream, const std::string& integratorName,
                                               std::uint64_t seed, std::uint64_t nextStream, const StepHistory& history,
                                               const StiffClockState& clock = StiffClockState(),
                                               const ProposalCounts& counts = ProposalCounts());

/**
 * Reads what writeFlowCheckpoint() wrote for integratorName into seed, nextStream and stored (checked against
 * history's number of particles) and, if clock and counts are not null, the stiff clock and the proposal counts.
 * Returns an empty string, or what the stream holds instead (another integrator's data, another format version, a
 * truncated or corrupt one), for flowCheckpointError().
 */
OPENMM_EXPORT_FLAVORS std::string readFlowCheckpoint(std::istream& stream, const std::string& integratorName,
                                                     const StepHistory& history, std::uint64_t& seed,
                                                     std::uint64_t& nextStream, StepHistory::Stored& stored,
                                                     StiffClockState* clock = nullptr,
                                                     ProposalCounts* counts = nullptr);

/** The message of a failed load: what the stream holds and that the Context keeps its state. */
OPENMM_EXPORT_FLAVORS std::string flowCheckpointError(const std::string& integratorName, const std::string& problem);

} // namespace FlavorPlugin

#endif

#ifndef OPENMM_FLAVORS_STEP_HISTORY_H_
#define OPENMM_FLAVORS_STEP_HISTORY_H_

#include "internal/windowsExportFlavors.h"
#include "openmm/Vec3.h"
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

namespace FlavorPlugin {

class StiffModes;

/**
 * What the next step takes from the last one, per particle: for Filtered steps, the change of the soft force on stiff
 * particles over the last step, whose velocity processing the next step undoes, and the velocity processing of the
 * constraint impulses that the last step added (ConstraintProjector::processVelocities), which the next step takes
 * off (docs/sim_drude.md).  Part of the integrator's checkpoint; forgotten when the Context's positions or velocities
 * are set from outside.
 */
class OPENMM_EXPORT_FLAVORS StepHistory {
public:
    explicit StepHistory(int numParticles);
    /** Forgets the history, unless it was loaded from a checkpoint since the last step (see markLoaded()). */
    void forget();
    /** A step starts: what forget() is asked from now on is a new state set from outside. */
    void stepStarted() { loaded = false; }
    /**
     * Keeps the history of particles that are still stiff after the stiff modes were measured again (after parameter
     * changes and checkpoints).
     */
    void keepOnly(const StiffModes* modes);
    /** Writes the history (the number of nonzero entries, then index and value of each, for both vectors). */
    void write(std::ostream& stream) const;
    /** A history as read from a checkpoint: (particle, value) of its nonzero entries. */
    struct Stored {
        std::vector<std::pair<int, OpenMM::Vec3>> differences, processing;
    };
    /**
     * Reads what write() wrote; false if the stream holds no valid history for this many particles.  olderFormat: the
     * history of checkpoint versions 2 to 4 (the constraint share forces of an older treatment of constrained stiff
     * components, skipped, then the force differences).
     */
    bool read(std::istream& stream, Stored& stored, bool olderFormat) const;
    /**
     * Makes a history read from a checkpoint the current one, kept through the forget() that OpenMM's announcement of
     * the checkpoint's positions and velocities makes before the next step.
     */
    void load(const Stored& stored);
    std::vector<OpenMM::Vec3> forceDifferences, constraintProcessing;
    /** The soft forces on stiff particles where the current Filtered step began (not part of the history). */
    std::vector<OpenMM::Vec3> openingForces;

private:
    bool loaded = false;
};

} // namespace FlavorPlugin

#endif

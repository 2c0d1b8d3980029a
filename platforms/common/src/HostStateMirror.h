#ifndef OPENMM_FLAVORS_HOST_STATE_MIRROR_H_
#define OPENMM_FLAVORS_HOST_STATE_MIRROR_H_

#include "openmm/Vec3.h"
#include "openmm/common/ArrayInterface.h"
#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeVectorTypes.h"
#include <vector>

namespace FlavorPlugin {

/**
 * Host copies of a common compute Context's positions and velocities in the System's particle order, for the parts
 * of a step that run the step engine's host code (HostFrozenStage, the SIM's constraint solves): download, change
 * them, upload.  Double, mixed (positions with their correction) and single precision; the fourth components
 * (charges, inverse masses) go back as they came, so an upload follows a download of the same array within one pass.
 * All buffers are sized at construction.
 */
class HostStateMirror {
public:
    HostStateMirror(OpenMM::ComputeContext& cc, int numParticles);
    /**
     * Copies the positions and/or the velocities from the device.  The copies (and one of `extra`, if given: another
     * device array into `extraTarget`, enqueued first) go on the in-order queue without waiting, all but the last,
     * which waits for them all: one synchronization per call, not one per array (on a GPU each costs a round trip).
     */
    void download(bool withPositions, bool withVelocities, const OpenMM::ArrayInterface* extra = nullptr,
                  void* extraTarget = nullptr);
    /** Copies the positions and/or the velocities to the device; as download(), only the last copy waits. */
    void upload(bool withPositions, bool withVelocities);
    /** Whether the platform keeps velocities and forces in double precision (double or mixed). */
    bool usesDoubles() const { return doubles || mixed; }
    std::vector<OpenMM::Vec3> positions, velocities;

private:
    OpenMM::ComputeContext& cc;
    const bool doubles, mixed;
    // The device arrays as downloaded (atom order, padded): double or single precision as the platform keeps them.
    std::vector<OpenMM::mm_double4> posqDouble, velmDouble;
    std::vector<OpenMM::mm_float4> posqFloat, correctionFloat, velmFloat;
};

} // namespace FlavorPlugin

#endif

#ifndef OPENMM_FLAVORS_DEVICE_FAILURE_FLAG_H_
#define OPENMM_FLAVORS_DEVICE_FAILURE_FLAG_H_

#include "openmm/common/ComputeArray.h"
#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeEvent.h"

namespace FlavorPlugin {

/**
 * One int on the device that the kernels of a step set when the step cannot go on (a frozen drift that cannot be
 * held, a Drude pair past twice the wall), read without stalling the device: downloaded without waiting where a step
 * that may have set it ends, and read where the next step starts.  The code says who set it (the kernels' own
 * convention); 0 is none.
 */
class DeviceFailureFlag {
public:
    explicit DeviceFailureFlag(OpenMM::ComputeContext& cc);
    /** Waits for a download still on its way. */
    ~DeviceFailureFlag();
    /** The device int for the kernels' arguments. */
    OpenMM::ComputeArray& getArray() { return flag; }
    /** A kernel that may set the flag ran in this step. */
    void markUsed() { usedThisStep = true; }
    /** Where a step ends: starts the download if the step may have set the flag, without waiting for it. */
    void finishStep();
    /** The code the last step left (0: none), after waiting for finishStep()'s download; clears it on the device. */
    int take();

private:
    OpenMM::ComputeContext& cc;
    OpenMM::ComputeArray flag;
    OpenMM::ComputeEvent read;
    bool usedThisStep = false, readPending = false;
    // Where the flag is downloaded to; read only after read has completed.
    int code = 0;
};

} // namespace FlavorPlugin

#endif

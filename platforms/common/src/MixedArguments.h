#ifndef OPENMM_FLAVORS_MIXED_ARGUMENTS_H_
#define OPENMM_FLAVORS_MIXED_ARGUMENTS_H_

#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeKernel.h"

namespace FlavorPlugin {

/** Whether the kernels' `mixed` type is double (double and mixed precision) or float (single). */
inline bool mixedIsDouble(const OpenMM::ComputeContext& cc) {
    return cc.getUseDoublePrecision() || cc.getUseMixedPrecision();
}

/**
 * A `mixed` scalar argument, in the size the kernel declares: OpenCL drivers that check argument sizes (NVIDIA's)
 * reject a double where a single-precision Context compiled a float.
 */
inline void addMixedArg(const OpenMM::ComputeContext& cc, OpenMM::ComputeKernel& kernel, double value) {
    if (mixedIsDouble(cc))
        kernel->addArg(value);
    else
        kernel->addArg((float)value);
}

inline void setMixedArg(const OpenMM::ComputeContext& cc, OpenMM::ComputeKernel& kernel, int index, double value) {
    if (mixedIsDouble(cc))
        kernel->setArg(index, value);
    else
        kernel->setArg(index, (float)value);
}

} // namespace FlavorPlugin

#endif

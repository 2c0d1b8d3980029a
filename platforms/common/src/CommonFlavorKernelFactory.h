#ifndef OPENMM_FLAVORS_COMMON_FLAVOR_KERNEL_FACTORY_H_
#define OPENMM_FLAVORS_COMMON_FLAVOR_KERNEL_FACTORY_H_

#include "CommonFlavorKernels.h"
#include "FlavorKernels.h"
#include "openmm/KernelFactory.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/internal/ContextImpl.h"
#include <string>

namespace FlavorPlugin {

/**
 * Creates the common-compute kernels of both integrators on a GPU platform's (first) ComputeContext.  PlatformType is
 * the platform's class (OpenCLPlatform, CudaPlatform): its PlatformData holds the contexts.  The platform's own context
 * header must be included first, so that its context converts to ComputeContext.
 */
template <class PlatformType> class CommonFlavorKernelFactory : public OpenMM::KernelFactory {
public:
    OpenMM::KernelImpl* createKernelImpl(std::string name, const OpenMM::Platform& platform,
                                         OpenMM::ContextImpl& context) const override {
        auto& data = *static_cast<typename PlatformType::PlatformData*>(context.getPlatformData());
        OpenMM::ComputeContext& cc = *data.contexts[0];
        if (name == IntegrateFlavorStepKernel::Name())
            return new CommonFlavorStepKernel(name, platform, cc);
        if (name == IntegrateStochasticImpulseStepKernel::Name())
            return new CommonImpulseStepKernel(name, platform, cc);
        throw OpenMM::OpenMMException("Tried to create kernel with illegal kernel name '" + name + "'");
    }
};

/**
 * Registers the kernels with the platform named platformName.  OpenMM registers a GPU platform only where its driver
 * exists (an OpenCL driver, an NVIDIA driver); without one there is nothing to do.
 */
template <class PlatformType> void registerCommonFlavorKernels(const std::string& platformName) {
    try {
        OpenMM::Platform& platform = OpenMM::Platform::getPlatformByName(platformName);
        auto* factory = new CommonFlavorKernelFactory<PlatformType>();
        platform.registerKernelFactory(IntegrateFlavorStepKernel::Name(), factory);
        platform.registerKernelFactory(IntegrateStochasticImpulseStepKernel::Name(), factory);
    } catch (const std::exception&) {
    }
}

} // namespace FlavorPlugin

#endif

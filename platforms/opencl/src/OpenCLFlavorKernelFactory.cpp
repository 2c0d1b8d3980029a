#include "CommonFlavorKernels.h"
#include "FlavorKernels.h"
#include "OpenCLContext.h"
#include "OpenCLPlatform.h"
#include "openmm/KernelFactory.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/internal/ContextImpl.h"

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

/** Creates the common-compute kernels on the OpenCL platform's (first) ComputeContext. */
class OpenCLFlavorKernelFactory : public KernelFactory {
public:
    KernelImpl* createKernelImpl(std::string name, const Platform& platform, ContextImpl& context) const override {
        OpenCLPlatform::PlatformData& data = *static_cast<OpenCLPlatform::PlatformData*>(context.getPlatformData());
        OpenCLContext& cl = *data.contexts[0];
        if (name == IntegrateFlavorStepKernel::Name())
            return new CommonFlavorStepKernel(name, platform, cl);
        if (name == IntegrateStochasticImpulseStepKernel::Name())
            return new CommonImpulseStepKernel(name, platform, cl);
        throw OpenMMException((std::string("Tried to create kernel with illegal kernel name '") + name + "'").c_str());
    }
};

void registerOpenCLKernels() {
    // Without an OpenCL driver OpenMM registers no OpenCL platform, and there is nothing to do.
    try {
        Platform& platform = Platform::getPlatformByName("OpenCL");
        OpenCLFlavorKernelFactory* factory = new OpenCLFlavorKernelFactory();
        platform.registerKernelFactory(IntegrateFlavorStepKernel::Name(), factory);
        platform.registerKernelFactory(IntegrateStochasticImpulseStepKernel::Name(), factory);
    } catch (const std::exception&) {
    }
}

} // namespace

// Defined (empty) so that dlsym does not find libOpenMMOpenCL's registerPlatforms and create a second OpenCL platform.
extern "C" OPENMM_EXPORT_FLAVORS void registerPlatforms() {}

extern "C" OPENMM_EXPORT_FLAVORS void registerKernelFactories() {
    registerOpenCLKernels();
}

/** Registers the OpenCL kernels when a program links this library directly (tests). */
extern "C" OPENMM_EXPORT_FLAVORS void registerFlavorOpenCLKernelFactories() {
    registerOpenCLKernels();
}

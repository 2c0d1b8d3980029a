#include "CommonFlavorKernelFactory.h"
#include "OpenCLContext.h"
#include "OpenCLPlatform.h"

using namespace FlavorPlugin;

// Defined (empty) so that dlsym does not find libOpenMMOpenCL's registerPlatforms and create a second OpenCL platform.
extern "C" OPENMM_EXPORT_FLAVORS void registerPlatforms() {}

extern "C" OPENMM_EXPORT_FLAVORS void registerKernelFactories() {
    registerCommonFlavorKernels<OpenMM::OpenCLPlatform>("OpenCL");
}

/** Registers the OpenCL kernels when a program links this library directly (tests). */
extern "C" OPENMM_EXPORT_FLAVORS void registerFlavorOpenCLKernelFactories() {
    registerCommonFlavorKernels<OpenMM::OpenCLPlatform>("OpenCL");
}

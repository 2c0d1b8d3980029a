#include "CommonFlavorKernelFactory.h"
#include "CudaContext.h"
#include "CudaPlatform.h"

using namespace FlavorPlugin;

// Defined (empty) so that dlsym does not find libOpenMMCUDA's registerPlatforms and create a second CUDA platform.
extern "C" OPENMM_EXPORT_FLAVORS void registerPlatforms() {}

extern "C" OPENMM_EXPORT_FLAVORS void registerKernelFactories() {
    registerCommonFlavorKernels<OpenMM::CudaPlatform>("CUDA");
}

/** Registers the CUDA kernels when a program links this library directly (tests). */
extern "C" OPENMM_EXPORT_FLAVORS void registerFlavorCudaKernelFactories() {
    registerCommonFlavorKernels<OpenMM::CudaPlatform>("CUDA");
}

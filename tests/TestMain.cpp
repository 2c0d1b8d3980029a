#include "openmm/Platform.h"
#include <gtest/gtest.h>

extern "C" void registerFlavorReferenceKernelFactories();
extern "C" void registerFlavorCpuKernelFactories();
#ifdef FLAVORS_HAVE_OPENCL
extern "C" void registerFlavorOpenCLKernelFactories();
#endif

int main(int argc, char** argv) {
    // OpenMM's own plugins first (the CPU and OpenCL platforms live there), then this project's kernels, and only then
    // the tests, whose platforms depend on which platforms exist (PlatformTest.h).
    OpenMM::Platform::loadPluginsFromDirectory(OPENMM_PLUGIN_DIR);
    registerFlavorReferenceKernelFactories();
    registerFlavorCpuKernelFactories();
#ifdef FLAVORS_HAVE_OPENCL
    registerFlavorOpenCLKernelFactories();
#endif
    ::testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}

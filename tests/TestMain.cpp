#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include <cstdlib>
#include <gtest/gtest.h>

extern "C" void registerFlavorReferenceKernelFactories();
extern "C" void registerFlavorCpuKernelFactories();
#ifdef FLAVORS_HAVE_OPENCL
extern "C" void registerFlavorOpenCLKernelFactories();
#endif

int main(int argc, char** argv) {
#ifdef FLAVORS_OPENCL_VENDORS
    // The build's OpenCL drivers, PoCL among them, which the machine need not register (the top CMakeLists.txt says
    // why), unless the caller names others; read when OpenMM's OpenCL platform first asks for devices.
    setenv("OCL_ICD_VENDORS", FLAVORS_OPENCL_VENDORS, 0);
#endif
    // OpenMM's own plugins first (the CPU, OpenCL and CUDA platforms live there), then this project's kernels, and only
    // then the tests, whose platforms depend on which platforms exist (PlatformTest.h).
    OpenMM::Platform::loadPluginsFromDirectory(OPENMM_PLUGIN_DIR);
    registerFlavorReferenceKernelFactories();
    registerFlavorCpuKernelFactories();
#ifdef FLAVORS_HAVE_OPENCL
    registerFlavorOpenCLKernelFactories();
#endif
#ifdef FLAVORS_HAVE_CUDA
    // OpenMM has a CUDA platform only where libOpenMMCUDA.so loaded (an NVIDIA driver exists); our plugin needs it.
    try {
        OpenMM::Platform::getPlatformByName("CUDA");
        OpenMM::Platform::loadPluginLibrary(FLAVORS_CUDA_PLUGIN);
    } catch (const OpenMM::OpenMMException&) {
    }
#endif
    ::testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}

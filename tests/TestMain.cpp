#include "openmm/Platform.h"
#include <gtest/gtest.h>

extern "C" void registerFlavorReferenceKernelFactories();
extern "C" void registerFlavorCpuKernelFactories();

int main(int argc, char** argv) {
    ::testing::InitGoogleTest(&argc, argv);
    // OpenMM's own plugins first (the CPU platform lives there), then this project's kernels.
    OpenMM::Platform::loadPluginsFromDirectory(OPENMM_PLUGIN_DIR);
    registerFlavorReferenceKernelFactories();
    registerFlavorCpuKernelFactories();
    return RUN_ALL_TESTS();
}

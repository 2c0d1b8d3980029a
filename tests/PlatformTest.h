#ifndef OPENMM_FLAVORS_TESTS_PLATFORM_TEST_H_
#define OPENMM_FLAVORS_TESTS_PLATFORM_TEST_H_

#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include <algorithm>
#include <gtest/gtest.h>
#include <map>
#include <string>
#include <vector>

namespace FlavorTests {

/**
 * The suites whose schemes or settings the GPU backend does not have yet, or that test the host step engine itself:
 * they run on Reference and CPU only.  Supporting one on the GPU platforms is deleting its line here.
 */
inline const std::vector<std::string>& suitesNotOnGpu() {
    static const std::vector<std::string> suites = {
        "EngineSchedules",    // runs the CPU-side engine (FlowStepRunner) on Reference and CPU particle data
        "FlavorAccuracy",     // blow-up past 1e50 (the GPU platforms' fixed-point forces saturate); a 20 s run on PoCL
        "ImpulseExact",       // stiffness to 1e-10 relative (fixed-point forces give 3e-10)
        "ImpulseFiltered",    // fixed points to 1e-10; the GPU platforms' force constants are single (k off by 3e-8)
        "StepAllocations",    // counts the CPU engine's allocations
        "StoredTrajectories", // trajectories stored bit for bit on Reference and CPU
        "ThreadedPaths",      // the CPU platform's thread pool
    };
    return suites;
}

/** The GPU platforms (OpenMM's common compute platforms) this build has a backend for. */
inline std::vector<std::string> gpuPlatformsBuilt() {
    std::vector<std::string> names;
#ifdef FLAVORS_HAVE_OPENCL
    names.push_back("OpenCL");
#endif
#ifdef FLAVORS_HAVE_CUDA
    names.push_back("CUDA");
#endif
    return names;
}

/**
 * The platforms a suite runs on: Reference and CPU, and each GPU platform (OpenCL, CUDA) that OpenMM has (an OpenCL
 * driver such as PoCL, an NVIDIA GPU and driver) and this build has a backend for, unless the suite is listed in
 * suitesNotOnGpu().  Evaluated when GoogleTest registers the tests, after TestMain has loaded the plugins.
 */
inline std::vector<std::string> platformsFor(const std::string& suite) {
    std::vector<std::string> names = {"Reference", "CPU"};
    const std::vector<std::string>& excluded = suitesNotOnGpu();
    if (std::find(excluded.begin(), excluded.end(), suite) != excluded.end())
        return names;
    for (const std::string& gpu : gpuPlatformsBuilt()) {
        try {
            OpenMM::Platform::getPlatformByName(gpu);
            names.push_back(gpu);
        } catch (const OpenMM::OpenMMException&) {
        }
    }
    return names;
}

} // namespace FlavorTests

/**
 * A test that runs once on each platform, like OpenMM's TestReference* and TestCpu* pairs.
 */
class PlatformTest : public ::testing::TestWithParam<std::string> {
protected:
    OpenMM::Platform& platform() const { return OpenMM::Platform::getPlatformByName(GetParam()); }
    bool isCpu() const { return GetParam() == "CPU"; }
    /**
     * The GPU platforms (OpenCL, CUDA) compute harmonic bond and angle forces about 1e-6 relative off Reference's even
     * in double precision (measured on PoCL: 6e-4 kJ/mol/nm of 815), accumulate forces in fixed point and hold System
     * constraints with their own SETTLE and CCMA to about 1e-9 nm.  Comparisons that hold to double rounding on
     * Reference and CPU hold there to what that allows: each test states its GPU bound beside the one it keeps
     * elsewhere.  The bounds were measured on OpenCL; CUDA runs the same kernels, in double precision with IEEE
     * arithmetic (its fast-math flags touch single-precision functions only).
     */
    bool isGpu() const { return GetParam() == "OpenCL" || GetParam() == "CUDA"; }
    /** Context properties; threads > 0 fixes the CPU platform's thread count.  GPU platforms run in double precision.
     */
    std::map<std::string, std::string> properties(int threads = 0) const {
        std::map<std::string, std::string> result;
        if (isCpu() && threads > 0)
            result["Threads"] = std::to_string(threads);
        if (isGpu())
            result["Precision"] = "double";
        return result;
    }
};

#define INSTANTIATE_ON_ALL_PLATFORMS(Suite)                                                                            \
    INSTANTIATE_TEST_SUITE_P(AllPlatforms, Suite, ::testing::ValuesIn(FlavorTests::platformsFor(#Suite)),              \
                             [](const ::testing::TestParamInfo<std::string>& info) { return info.param; })

#endif

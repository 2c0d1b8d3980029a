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
 * The suites whose schemes or settings the OpenCL backend does not have yet, or that test the host step engine
 * itself: they run on Reference and CPU only.  Supporting one on OpenCL is deleting its line here.
 */
inline const std::vector<std::string>& suitesNotOnOpenCL() {
    static const std::vector<std::string> suites = {
        "EngineSchedules",    // runs the CPU-side engine (FlowStepRunner) on Reference and CPU particle data
        "FlavorAccuracy",     // blow-up past 1e50 (OpenCL's fixed-point forces saturate); a 20 s run on PoCL
        "ImpulseExact",       // stiffness to 1e-10 relative (fixed-point forces give 3e-10)
        "ImpulseFiltered",    // fixed points to 1e-10; OpenCL's force constants are single (k off by 3e-8)
        "MetropolisAdjusted", // the Metropolis adjustment (setMetropolis)
        "StepAllocations",    // counts the CPU engine's allocations
        "StoredTrajectories", // trajectories stored bit for bit on Reference and CPU
        "ThreadedPaths",      // the CPU platform's thread pool
    };
    return suites;
}

/**
 * The platforms a suite runs on: Reference and CPU, and OpenCL where OpenMM has an OpenCL platform (an OpenCL
 * driver, e.g. PoCL, is installed), this build has the OpenCL backend, and the suite is not listed in
 * suitesNotOnOpenCL().  Evaluated when GoogleTest registers the tests, after TestMain has loaded the plugins.
 */
inline std::vector<std::string> platformsFor(const std::string& suite) {
    std::vector<std::string> names = {"Reference", "CPU"};
#ifdef FLAVORS_HAVE_OPENCL
    const std::vector<std::string>& excluded = suitesNotOnOpenCL();
    if (std::find(excluded.begin(), excluded.end(), suite) == excluded.end()) {
        try {
            OpenMM::Platform::getPlatformByName("OpenCL");
            names.push_back("OpenCL");
        } catch (const OpenMM::OpenMMException&) {
        }
    }
#else
    (void)suite;
#endif
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
     * OpenCL computes harmonic bond and angle forces about 1e-6 relative off Reference's even in double precision
     * (measured on PoCL: 6e-4 kJ/mol/nm of 815), accumulates forces in fixed point and holds System constraints with
     * its own SETTLE and CCMA to about 1e-9 nm.  Comparisons that hold to double rounding on Reference and CPU hold
     * there to what that allows: each test states its OpenCL bound beside the one it keeps elsewhere.
     */
    bool isOpenCL() const { return GetParam() == "OpenCL"; }
    /** Context properties; threads > 0 fixes the CPU platform's thread count.  OpenCL runs in double precision. */
    std::map<std::string, std::string> properties(int threads = 0) const {
        std::map<std::string, std::string> result;
        if (isCpu() && threads > 0)
            result["Threads"] = std::to_string(threads);
        if (isOpenCL())
            result["Precision"] = "double";
        return result;
    }
};

#define INSTANTIATE_ON_ALL_PLATFORMS(Suite)                                                                            \
    INSTANTIATE_TEST_SUITE_P(AllPlatforms, Suite, ::testing::ValuesIn(FlavorTests::platformsFor(#Suite)),              \
                             [](const ::testing::TestParamInfo<std::string>& info) { return info.param; })

#endif

#ifndef OPENMM_FLAVORS_TESTS_PLATFORM_TEST_H_
#define OPENMM_FLAVORS_TESTS_PLATFORM_TEST_H_

#include "openmm/Platform.h"
#include <gtest/gtest.h>
#include <map>
#include <string>

/**
 * A test that runs once on each platform, like OpenMM's TestReference* and TestCpu* pairs.
 */
class PlatformTest : public ::testing::TestWithParam<std::string> {
protected:
    OpenMM::Platform& platform() const { return OpenMM::Platform::getPlatformByName(GetParam()); }
    bool isCpu() const { return GetParam() == "CPU"; }
    /** Context properties; threads > 0 fixes the CPU platform's thread count. */
    std::map<std::string, std::string> properties(int threads = 0) const {
        std::map<std::string, std::string> result;
        if (isCpu() && threads > 0)
            result["Threads"] = std::to_string(threads);
        return result;
    }
};

#define INSTANTIATE_ON_ALL_PLATFORMS(Suite)                                                                            \
    INSTANTIATE_TEST_SUITE_P(AllPlatforms, Suite, ::testing::Values("Reference", "CPU"),                               \
                             [](const ::testing::TestParamInfo<std::string>& info) { return info.param; })

#endif

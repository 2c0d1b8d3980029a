#ifndef OPENMM_FLAVORS_TESTS_EXPECT_REJECTED_H_
#define OPENMM_FLAVORS_TESTS_EXPECT_REJECTED_H_

#include "openmm/OpenMMException.h"
#include <functional>
#include <gtest/gtest.h>
#include <string>
#include <vector>

namespace FlavorTests {

/** Expects action to throw an OpenMMException whose message contains every one of the given fragments. */
inline void expectRejected(const std::function<void()>& action, const std::vector<std::string>& fragments) {
    try {
        action();
        ADD_FAILURE() << "no exception; expected one mentioning " << fragments[0];
    } catch (const OpenMM::OpenMMException& e) {
        std::string message = e.what();
        for (const std::string& fragment : fragments)
            EXPECT_NE(std::string::npos, message.find(fragment)) << "'" << message << "' lacks '" << fragment << "'";
    }
}

} // namespace FlavorTests

#endif

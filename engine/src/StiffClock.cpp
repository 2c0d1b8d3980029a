#include "StiffClock.h"
#include <limits>

using namespace FlavorPlugin;

void StiffClock::configure(const std::string& name, double microStep, double mesoStep) {
    // A clock that ran with other time scales starts afresh; one loaded from a checkpoint before the first step
    // continues.
    if (isOn() && (name.empty() || microStep != advance || microStep / mesoStep != ratio))
        state.time = std::numeric_limits<double>::quiet_NaN();
    parameter = name;
    advance = microStep;
    ratio = microStep / mesoStep;
}

double StiffClock::startStep(double time) {
    // The clock continues where the last step left it unless the time was set from outside (or it never ran).
    if (isOn() && time != state.time)
        state.clock = time * ratio;
    return state.clock;
}

void StiffClock::endStep(double time) {
    if (!isOn())
        return;
    state.clock += advance;
    state.time = time;
}

#include "DeviceFailureFlag.h"

using namespace FlavorPlugin;
using namespace OpenMM;

DeviceFailureFlag::DeviceFailureFlag(ComputeContext& cc) : cc(cc) {
    flag.initialize<int>(cc, 1, "flavorFailure");
    cc.clearBuffer(flag);
    read = cc.createEvent();
}

DeviceFailureFlag::~DeviceFailureFlag() {
    if (readPending)
        read->wait();
}

void DeviceFailureFlag::finishStep() {
    if (!usedThisStep)
        return;
    usedThisStep = false;
    flag.download(&code, false);
    read->enqueue();
    readPending = true;
}

int DeviceFailureFlag::take() {
    if (!readPending)
        return 0;
    read->wait();
    readPending = false;
    const int taken = code;
    if (taken != 0) {
        code = 0;
        cc.clearBuffer(flag);
    }
    return taken;
}

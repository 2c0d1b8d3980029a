#include "ContextRollback.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

ReferencePlatform::PlatformData& platformData(ContextImpl& context) {
    return *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
}

} // namespace

void ContextRollback::save(ContextImpl& context, bool withParameters) {
    ReferencePlatform::PlatformData& data = platformData(context);
    positions = *data.positions;
    velocities = *data.velocities;
    boxSize = *data.periodicBoxSize;
    for (int i = 0; i < 3; ++i)
        boxVectors[i] = data.periodicBoxVectors[i];
    time = data.time;
    stepCount = data.stepCount;
    if (withParameters || !valid)
        parameters = context.getParameters();
    valid = true;
}

void ContextRollback::restore(ContextImpl& context) {
    if (!valid)
        return;
    ReferencePlatform::PlatformData& data = platformData(context);
    *data.positions = positions;
    *data.velocities = velocities;
    *data.periodicBoxSize = boxSize;
    for (int i = 0; i < 3; ++i)
        data.periodicBoxVectors[i] = boxVectors[i];
    data.time = time;
    data.stepCount = stepCount;
    // setParameter() notifies the integrator, which saves the state again: iterate over a copy.
    const std::map<std::string, double> saved = parameters;
    for (const auto& parameter : saved) {
        const std::map<std::string, double>& current = context.getParameters();
        auto found = current.find(parameter.first);
        if (found != current.end() && found->second != parameter.second)
            context.setParameter(parameter.first, parameter.second);
    }
}

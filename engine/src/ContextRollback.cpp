#include "ContextRollback.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

/** The particle data of Reference and CPU Contexts; null on other platforms. */
ReferencePlatform::PlatformData* referenceData(ContextImpl& context) {
    const std::string name = context.getPlatform().getName();
    if (name != "Reference" && name != "CPU")
        return nullptr;
    return reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
}

} // namespace

void ContextRollback::save(ContextImpl& context, bool withParameters) {
    ReferencePlatform::PlatformData* reference = referenceData(context);
    if (reference == nullptr) {
        context.getPositions(positions);
        context.getVelocities(velocities);
        context.getPeriodicBoxVectors(boxVectors[0], boxVectors[1], boxVectors[2]);
        time = context.getTime();
        stepCount = context.getStepCount();
    } else {
        ReferencePlatform::PlatformData& data = *reference;
        positions = *data.positions;
        velocities = *data.velocities;
        boxSize = *data.periodicBoxSize;
        for (int i = 0; i < 3; ++i)
            boxVectors[i] = data.periodicBoxVectors[i];
        time = data.time;
        stepCount = data.stepCount;
    }
    if (withParameters || !valid)
        parameters = context.getParameters();
    valid = true;
}

void ContextRollback::saveAllButParticles(ContextImpl& context, bool withParameters) {
    context.getPeriodicBoxVectors(boxVectors[0], boxVectors[1], boxVectors[2]);
    time = context.getTime();
    stepCount = context.getStepCount();
    if (withParameters || !valid)
        parameters = context.getParameters();
    valid = true;
}

void ContextRollback::restore(ContextImpl& context) {
    if (!valid)
        return;
    ReferencePlatform::PlatformData* reference = referenceData(context);
    if (reference == nullptr) {
        // Each setter notifies the integrator, which saves the state again: set from copies.
        const std::vector<Vec3> savedPositions = positions, savedVelocities = velocities;
        const Vec3 a = boxVectors[0], b = boxVectors[1], c = boxVectors[2];
        const double savedTime = time;
        const long long savedStepCount = stepCount;
        context.setPeriodicBoxVectors(a, b, c);
        context.setPositions(savedPositions);
        context.setVelocities(savedVelocities);
        context.setTime(savedTime);
        context.setStepCount(savedStepCount);
    } else {
        ReferencePlatform::PlatformData& data = *reference;
        *data.positions = positions;
        *data.velocities = velocities;
        *data.periodicBoxSize = boxSize;
        for (int i = 0; i < 3; ++i)
            data.periodicBoxVectors[i] = boxVectors[i];
        data.time = time;
        data.stepCount = stepCount;
    }
    // setParameter() notifies the integrator, which saves the state again: iterate over a copy.
    const std::map<std::string, double> saved = parameters;
    for (const auto& parameter : saved) {
        const std::map<std::string, double>& current = context.getParameters();
        auto found = current.find(parameter.first);
        if (found != current.end() && found->second != parameter.second)
            context.setParameter(parameter.first, parameter.second);
    }
}

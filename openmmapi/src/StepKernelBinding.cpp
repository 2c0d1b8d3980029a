#include "internal/StepKernelBinding.h"
#include "FlavorKernels.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include <limits>

using namespace FlavorPlugin;
using namespace OpenMM;

Kernel StepKernelBinding::createKernel(ContextImpl& context, const std::string& name) {
    return context.getPlatform().createKernel(name, context);
}

void StepKernelBinding::bound(ContextImpl& context) {
    stepKernel->saveContextState(context, true);
    forcesValid = false;
    stiffModesValid = false;
}

void StepKernelBinding::release() {
    stepKernel = nullptr;
    kernel = Kernel();
}

void StepKernelBinding::stateChanged(ContextImpl& context, State::DataType changed) {
    forcesValid = false;
    // Parameters: a context parameter changed.  Energy: a force's updateParametersInContext() (or a checkpoint).
    if (changed == State::Parameters || changed == State::Energy)
        stiffModesValid = false;
    if (stepKernel == nullptr)
        return;
    if (changed != State::Energy)
        stepKernel->saveContextState(context, changed == State::Parameters);
    if (changed == State::Positions || changed == State::Velocities)
        stepKernel->forgetStepHistory();
}

void StepKernelBinding::beforeStep(ContextImpl& context) {
    if (context.updateContextState())
        forcesValid = false;
}

void StepKernelBinding::afterSteps(ContextImpl& context, int steps) {
    if (steps > 0)
        stepKernel->saveContextState(context, false);
}

void StepKernelBinding::createCheckpoint(ContextImpl& context, std::ostream& stream) const {
    stepKernel->createCheckpoint(context, stream);
}

void StepKernelBinding::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    stepKernel->loadCheckpoint(context, stream);
    forcesValid = false;
}

double StepKernelBinding::getAcceptanceRate(const std::string& owner) const {
    if (stepKernel == nullptr)
        throw OpenMMException(owner + ": getAcceptanceRate: the integrator is not bound to a Context");
    long long proposed = 0, accepted = 0;
    stepKernel->getProposalCounts(proposed, accepted);
    return proposed == 0 ? std::numeric_limits<double>::quiet_NaN() : (double)accepted / (double)proposed;
}

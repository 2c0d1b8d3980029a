#include "ImpulseStepKernel.h"
#include "ConstraintProjector.h"
#include "StiffProbe.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;

ImpulseStepKernel::ImpulseStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : RunnerKernel(name, platform, "StochasticImpulseIntegrator"), loop(std::move(loop)), configured(false) {}

void ImpulseStepKernel::initialize(const System& system, const StochasticImpulseIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    measurement = std::make_unique<StiffModesMeasurement>(system, "StochasticImpulseIntegrator",
                                                          "use FlavorIntegrator for nonlinear stiff forces");
}

void ImpulseStepKernel::measureStiffModes(ContextImpl& context, int stiffGroups) {
    // Constraints may join a stiff component to particles outside it; the runner lets the constrained particle carry
    // its component through the constraint solve.
    auto checkConstraints = [&context](const StiffModes& modes) {
        ConstraintProjector::rejectUncarriedConstraints(context, modes);
    };
    if (measurement->measure(context, stiffGroups, checkConstraints))
        runner->setStiffModes(measurement->getModes());
}

void ImpulseStepKernel::execute(ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                                bool& stiffModesValid) {
    const ImpulseParameters current = impulseParameters(integrator);
    validateImpulseStep(current);
    validateMetropolis(current, context.getSystem().getNumConstraints() > 0);
    if (!configured || !(current == parameters)) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        runner->setSchedule(impulseSchedule(parameters));
        configured = true;
    }
    if (!stiffModesValid || !measurement->getModes()) {
        measureStiffModes(context, parameters.stiffGroups);
        stiffModesValid = true;
    }
    runner->step(context, integrator.getConstraintTolerance(), parameters.stepSize, forcesValid);
}

std::vector<double> ImpulseStepKernel::getStiffModeFrequencies(ContextImpl& context,
                                                               const StochasticImpulseIntegrator& integrator,
                                                               bool& stiffModesValid) {
    if (!stiffModesValid || !measurement->getModes()) {
        measureStiffModes(context, integrator.getStiffGroups());
        stiffModesValid = true;
    }
    return measurement->getModes()->getStiffFrequencies();
}

double ImpulseStepKernel::computeKineticEnergy(ContextImpl& context,
                                               const StochasticImpulseIntegrator& /*integrator*/) {
    return runner->kineticEnergy(context);
}

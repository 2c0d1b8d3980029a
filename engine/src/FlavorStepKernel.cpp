#include "FlavorStepKernel.h"
#include "openmm/internal/ContextImpl.h"

using namespace FlavorPlugin;
using namespace OpenMM;

FlavorStepKernel::FlavorStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : RunnerKernel(name, platform, "FlavorIntegrator"), loop(std::move(loop)) {}

void FlavorStepKernel::initialize(const System& system, const FlavorIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    control = std::make_unique<FlavorStepControl>(system, *runner, getPlatform().getName());
}

void FlavorStepKernel::execute(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                               bool& stiffModesValid) {
    control->step(context, integrator, forcesValid, stiffModesValid);
}

double FlavorStepKernel::computeKineticEnergy(ContextImpl& context, const FlavorIntegrator& /*integrator*/) {
    return runner->kineticEnergy(context);
}

int FlavorStepKernel::getFrozenSet() const {
    return (int)control->getFrozenCoordinates().getFrozenSet();
}

int FlavorStepKernel::getNumFrozen() const {
    return control->getFrozenCoordinates().getNumFrozen();
}

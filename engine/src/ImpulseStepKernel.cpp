#include "ImpulseStepKernel.h"
#include "openmm/internal/ContextImpl.h"

using namespace FlavorPlugin;
using namespace OpenMM;

ImpulseStepKernel::ImpulseStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : RunnerKernel(name, platform, "StochasticImpulseIntegrator"), loop(std::move(loop)) {}

void ImpulseStepKernel::initialize(const System& system, const StochasticImpulseIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    control = std::make_unique<ImpulseStepControl>(system, *runner, getPlatform().getName());
}

void ImpulseStepKernel::execute(ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                                bool& stiffModesValid) {
    control->step(context, integrator, forcesValid, stiffModesValid);
}

std::vector<double> ImpulseStepKernel::getStiffModeFrequencies(ContextImpl& context,
                                                               const StochasticImpulseIntegrator& integrator,
                                                               bool& stiffModesValid) {
    return control->getStiffModeFrequencies(context, integrator.getStiffGroups(), stiffModesValid);
}

std::vector<double> ImpulseStepKernel::getWarpedPhaseChoice(ContextImpl& context,
                                                            const StochasticImpulseIntegrator& integrator,
                                                            bool& stiffModesValid) {
    const WarpedPhaseChoice* choice = control->getWarpedPhaseChoice(context, integrator, stiffModesValid);
    if (choice == nullptr)
        return {};
    return {choice->phase, choice->couplingRatio, choice->seconds};
}

double ImpulseStepKernel::computeKineticEnergy(ContextImpl& context,
                                               const StochasticImpulseIntegrator& /*integrator*/) {
    return runner->kineticEnergy(context);
}

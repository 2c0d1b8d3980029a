#include "FlavorStepKernel.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

FlavorStepKernel::FlavorStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : RunnerKernel(name, platform, "FlavorIntegrator"), loop(std::move(loop)), configured(false) {}

void FlavorStepKernel::initialize(const System& system, const FlavorIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    frozen = std::make_unique<FrozenCoordinates>(system);
}

void FlavorStepKernel::execute(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                               bool& stiffModesValid) {
    FlavorParameters current = flavorParameters(integrator);
    current.frozen = frozen->getScheduledSet();
    validateFlavorStep(current);
    // The artificial averagings freeze the nonzero modes of the stiff potential, measured where the first step starts
    // and again after anything that may change it.
    if (current.averaging != FlavorIntegrator::Nonintrusive &&
        (!stiffModesValid || frozen->getFrozenSet() == SubFlow::FrozenSet::None)) {
        if (frozen->determine(context, integrator, current)) {
            if (!frozen->getDistances())
                runner->setStiffModes(frozen->getModes());
            runner->setFrozenDistances(frozen->getDistances());
        }
        stiffModesValid = true;
        current.frozen = frozen->getScheduledSet();
        validateFlavorStep(current);
    }
    validateMetropolis(current, context.getSystem().getNumConstraints() > 0);
    if (!configured || !(current == parameters) || integrator.getStiffClockParameter() != clockParameter) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        clockParameter = integrator.getStiffClockParameter();
        runner->setSchedule(flavorSchedule(parameters));
        runner->setStiffClock(clockParameter, parameters.microStep, parameters.mesoStep);
        configured = true;
    }
    runner->setFrictionParticles(integrator.getFrictionParticles());
    runner->step(context, integrator.getConstraintTolerance(), integrator.getMesoStep(), forcesValid);
}

double FlavorStepKernel::computeKineticEnergy(ContextImpl& context, const FlavorIntegrator& /*integrator*/) {
    return runner->kineticEnergy(context);
}

int FlavorStepKernel::getFrozenSet() const {
    return (int)frozen->getFrozenSet();
}

int FlavorStepKernel::getNumFrozen() const {
    return frozen->getNumFrozen();
}

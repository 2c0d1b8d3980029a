#include "FlavorStepKernel.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/SimTKOpenMMRealType.h"

using namespace FlavorPlugin;
using namespace OpenMM;

FlavorStepKernel::FlavorStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : IntegrateFlavorStepKernel(name, platform), loop(std::move(loop)), configured(false), kT(0.0) {}

void FlavorStepKernel::initialize(const System& system, const FlavorIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    measurement = std::make_unique<StiffModesMeasurement>(
        system, "FlavorIntegrator",
        "use the Nonintrusive averaging (FlavorIntegrator::setAveraging) for nonlinear stiff forces");
}

void FlavorStepKernel::execute(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                               bool& stiffModesValid) {
    FlavorParameters current{integrator.getScheme(),
                             integrator.getAveraging(),
                             integrator.getExactFastFlow(),
                             integrator.getMesoStep(),
                             integrator.getMicroStep(),
                             integrator.getStiffGroups(),
                             integrator.getIntegrationForceGroups(),
                             integrator.getFriction(),
                             integrator.getStiffFriction()};
    const double currentKT = BOLTZ * integrator.getTemperature();
    if (!configured || !(current == parameters) || currentKT != kT) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        kT = currentKT;
        runner->setSchedule(flavorSchedule(parameters), kT, parameters.friction);
        configured = true;
    }
    // The artificial averagings freeze the nonzero modes of the stiff potential, measured where the first step starts
    // and again after anything that may change it.
    if (parameters.averaging != FlavorIntegrator::Nonintrusive && (!stiffModesValid || !measurement->getModes())) {
        if (measurement->measure(context, parameters.stiffGroups))
            runner->setStiffModes(measurement->getModes());
        stiffModesValid = true;
    }
    runner->setFrictionParticles(integrator.getFrictionParticles());
    runner->step(context, integrator.getConstraintTolerance(), integrator.getMesoStep(), forcesValid);
}

double FlavorStepKernel::computeKineticEnergy(ContextImpl& context, const FlavorIntegrator& integrator) {
    return runner->kineticEnergy(context);
}

void FlavorStepKernel::createCheckpoint(ContextImpl& context, std::ostream& stream) const {
    runner->createCheckpoint(stream);
}

void FlavorStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    runner->loadCheckpoint(stream);
}

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
}

void FlavorStepKernel::execute(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid) {
    FlavorParameters current{integrator.getScheme(),
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
    runner->setFrictionParticles(integrator.getFrictionParticles());
    runner->step(context, integrator.getConstraintTolerance(), integrator.getMesoStep(), forcesValid);
}

double FlavorStepKernel::computeKineticEnergy(ContextImpl& context, const FlavorIntegrator& /*integrator*/) {
    return runner->kineticEnergy(context);
}

void FlavorStepKernel::createCheckpoint(ContextImpl& /*context*/, std::ostream& stream) const {
    runner->createCheckpoint(stream, "FlavorIntegrator");
}

void FlavorStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    runner->loadCheckpoint(context, stream, "FlavorIntegrator");
}

void FlavorStepKernel::saveContextState(ContextImpl& context, bool withParameters) {
    runner->saveContextState(context, withParameters);
}

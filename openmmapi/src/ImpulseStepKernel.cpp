#include "internal/ImpulseStepKernel.h"
#include "internal/FlavorStepKernel.h"
#include "internal/StiffProbe.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"
#include "openmm/reference/SimTKOpenMMRealType.h"

using namespace FlavorPlugin;
using namespace OpenMM;

ImpulseStepKernel::ImpulseStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : IntegrateStochasticImpulseStepKernel(name, platform), loop(std::move(loop)), configured(false), kT(0.0),
      friction(0.0) {}

void ImpulseStepKernel::initialize(const System& system, const StochasticImpulseIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    masses.resize(system.getNumParticles());
    for (int i = 0; i < system.getNumParticles(); ++i)
        masses[i] = system.getParticleMass(i);
}

void ImpulseStepKernel::measureStiffModes(ContextImpl& context, int stiffGroups) {
    ProbedStiffness stiffness = probeStiffness(context, stiffGroups, masses);
    auto measured = std::make_shared<const StiffModes>(masses, stiffness.blocks, stiffness.constantForce);
    std::vector<bool> stiff(masses.size());
    for (size_t i = 0; i < masses.size(); ++i)
        stiff[i] = measured->isStiffParticle((int)i);
    rejectConstrainedStiffParticles(context, stiff);
    modes = measured;
    runner->setStiffModes(modes);
}

void ImpulseStepKernel::execute(ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                                bool& stiffModesValid) {
    ImpulseParameters current{(ImpulseParameters::Splitting)integrator.getSplitting(), integrator.getStepSize(),
                              integrator.getStiffGroups(), integrator.getIntegrationForceGroups()};
    const double currentKT = BOLTZ * integrator.getTemperature();
    if (!configured || !(current == parameters) || currentKT != kT || integrator.getFriction() != friction) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        kT = currentKT;
        friction = integrator.getFriction();
        runner->setSchedule(impulseSchedule(parameters), kT, friction);
        configured = true;
    }
    if (!stiffModesValid || !modes) {
        measureStiffModes(context, parameters.stiffGroups);
        stiffModesValid = true;
    }
    runner->step(context, integrator.getConstraintTolerance(), forcesValid);
    ReferencePlatform::PlatformData& data =
        *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
    data.time += parameters.stepSize;
    data.stepCount++;
}

std::vector<double> ImpulseStepKernel::getStiffModeFrequencies(ContextImpl& context,
                                                               const StochasticImpulseIntegrator& integrator,
                                                               bool& stiffModesValid) {
    if (!stiffModesValid || !modes) {
        measureStiffModes(context, integrator.getStiffGroups());
        stiffModesValid = true;
    }
    return modes->getStiffFrequencies();
}

double ImpulseStepKernel::computeKineticEnergy(ContextImpl& context, const StochasticImpulseIntegrator& integrator) {
    return runner->kineticEnergy(context);
}

void ImpulseStepKernel::createCheckpoint(ContextImpl& context, std::ostream& stream) const {
    runner->createCheckpoint(stream);
}

void ImpulseStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    runner->loadCheckpoint(stream);
}

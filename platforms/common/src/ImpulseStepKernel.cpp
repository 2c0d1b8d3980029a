#include "ImpulseStepKernel.h"
#include "StiffProbe.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;

ImpulseStepKernel::ImpulseStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : IntegrateStochasticImpulseStepKernel(name, platform), loop(std::move(loop)), configured(false),
      placement(StochasticImpulseIntegrator::Throughout), kT(0.0), friction(0.0), stiffKT(0.0), stiffFriction(0.0) {}

void ImpulseStepKernel::initialize(const System& system, const StochasticImpulseIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    measurement = std::make_unique<StiffModesMeasurement>(system, "StochasticImpulseIntegrator",
                                                          "use FlavorIntegrator for nonlinear stiff forces");
}

void ImpulseStepKernel::measureStiffModes(ContextImpl& context, int stiffGroups) {
    auto checkConstraints = [&context](const StiffModes& modes) {
        // Constraints may join a stiff component to particles outside it; the runner lets the constrained particle
        // carry its component through the constraint solve.
        std::vector<int> componentOf(context.getSystem().getNumParticles(), -1);
        for (int c = 0; c < modes.getNumComponents(); ++c)
            if (modes.getComponent(c).stiff)
                for (int k = 0; k < modes.getComponent(c).numParticles; ++k)
                    componentOf[modes.getComponentParticles(c)[k]] = modes.getComponentParticles(c)[0];
        rejectConstraintsInsideStiffComponents(context, componentOf);
    };
    if (measurement->measure(context, stiffGroups, checkConstraints))
        runner->setStiffModes(measurement->getModes());
}

void ImpulseStepKernel::execute(ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                                bool& stiffModesValid) {
    ImpulseParameters current{integrator.getSplitting(), integrator.getStepSize(), integrator.getStiffGroups(),
                              integrator.getIntegrationForceGroups()};
    const StochasticImpulseIntegrator::ThermostatPlacement currentPlacement = integrator.getThermostatPlacement();
    if (currentPlacement == StochasticImpulseIntegrator::Middle &&
        current.splitting != StochasticImpulseIntegrator::Filtered &&
        current.splitting != StochasticImpulseIntegrator::Warped)
        throw OpenMMException("StochasticImpulseIntegrator: thermostatPlacement = Middle (1) is not allowed with "
                              "splitting = " +
                              std::to_string((int)current.splitting) +
                              " (its kicks act on whole particles, not mode by mode); allowed: Throughout (0) with "
                              "every splitting, Middle with Filtered (3) and Warped (4)");
    const double currentKT = BOLTZ * integrator.getTemperature();
    const double currentStiffKT = BOLTZ * integrator.getStiffModeTemperature();
    if (!configured || !(current == parameters) || currentPlacement != placement || currentKT != kT ||
        integrator.getFriction() != friction || currentStiffKT != stiffKT ||
        integrator.getStiffModeFriction() != stiffFriction) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        placement = currentPlacement;
        kT = currentKT;
        friction = integrator.getFriction();
        stiffKT = currentStiffKT;
        stiffFriction = integrator.getStiffModeFriction();
        runner->setSchedule(impulseSchedule(parameters), kT, friction);
        runner->setStiffModeBath(stiffKT, stiffFriction);
        runner->setBiasRemoval(parameters.splitting == StochasticImpulseIntegrator::Warped
                                   ? StiffModes::BiasRemoval::WarpedFlow
                                   : StiffModes::BiasRemoval::ScaledKicks);
        runner->setMiddleZeroModes(placement == StochasticImpulseIntegrator::Middle);
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

void ImpulseStepKernel::createCheckpoint(ContextImpl& /*context*/, std::ostream& stream) const {
    runner->createCheckpoint(stream, "StochasticImpulseIntegrator");
}

void ImpulseStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    runner->loadCheckpoint(context, stream, "StochasticImpulseIntegrator");
}

void ImpulseStepKernel::saveContextState(ContextImpl& context, bool withParameters) {
    runner->saveContextState(context, withParameters);
}

void ImpulseStepKernel::forgetStepHistory() {
    runner->forgetStepHistory();
}

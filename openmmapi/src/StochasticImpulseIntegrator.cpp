#include "StochasticImpulseIntegrator.h"
#include "FlavorKernels.h"
#include "internal/FlowSchedule.h"
#include "internal/ParameterChecks.h"
#include "internal/StepKernelBinding.h"
#include "internal/StiffGroupChecks.h"
#include "internal/StiffVelocities.h"
#include "openmm/Context.h"
#include "openmm/Force.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

namespace {

const string Owner = "StochasticImpulseIntegrator";

} // namespace

StochasticImpulseIntegrator::StochasticImpulseIntegrator(double temperature, double frictionCoeff, double stepSize,
                                                         int stiffGroups)
    : temperature(0.0), friction(0.0), stiffModeTemperature(-1.0), stiffModeFriction(-1.0), stiffGroups(0),
      splitting(Strang), thermostatPlacement(Throughout), randomNumberSeed(0), stepKernel(nullptr) {
    requireNonNegative(Owner, "temperature", temperature, "K");
    requireNonNegative(Owner, "friction", frictionCoeff, "1/ps");
    requirePositive(Owner, "stepSize", stepSize, "ps");
    requireGroupMask(Owner, "stiffGroups", stiffGroups);
    this->temperature = temperature;
    this->friction = frictionCoeff;
    this->stiffGroups = stiffGroups;
    Integrator::setStepSize(stepSize);
    setConstraintTolerance(1e-5);
}

void StochasticImpulseIntegrator::setStepSize(double size) {
    requirePositive(Owner, "stepSize", size, "ps");
    Integrator::setStepSize(size);
}

void StochasticImpulseIntegrator::setTemperature(double temp) {
    requireNonNegative(Owner, "temperature", temp, "K");
    temperature = temp;
}

void StochasticImpulseIntegrator::setFriction(double coeff) {
    requireNonNegative(Owner, "friction", coeff, "1/ps");
    validateSplitting(splitting, coeff, "friction");
    friction = coeff;
}

void StochasticImpulseIntegrator::setStiffModeTemperature(double temp) {
    requireNonNegative(Owner, "stiffModeTemperature", temp, "K");
    stiffModeTemperature = temp;
}

void StochasticImpulseIntegrator::setStiffModeFriction(double coeff) {
    requireNonNegative(Owner, "stiffModeFriction", coeff, "1/ps");
    validateSplitting(splitting, coeff, "stiffModeFriction");
    stiffModeFriction = coeff;
}

void StochasticImpulseIntegrator::setMaxDrudeDistance(double distance) {
    requireNonNegative(Owner, "maxDrudeDistance", distance, "nm");
    maxDrudeDistance = distance;
}

void StochasticImpulseIntegrator::setMaxWarpedPhase(double phase) {
    // Written so that NaN fails too.
    if (!(phase == 0.0 || (phase > 0.0 && phase <= M_PI)))
        throwInvalidParameter(Owner, "maxWarpedPhase", formatNumber(phase),
                              "maxWarpedPhase must be 0 (chosen from the System), pi (no limit) or an angle between 0 "
                              "and pi radians");
    maxWarpedPhase = phase;
}

void StochasticImpulseIntegrator::setStiffGroups(int groups) {
    requireGroupMask(Owner, "stiffGroups", groups);
    if (context != nullptr) {
        requireForceInGroups(Owner, context->getSystem(), groups);
        requireStiffGroupsIntegrated(Owner, "stiffGroups", groups, getIntegrationForceGroups());
    }
    stiffGroups = groups;
    binding.stiffModesValid = false;
}

void StochasticImpulseIntegrator::setIntegrationForceGroups(int groups) {
    if (context != nullptr)
        requireStiffGroupsIntegrated(Owner, "integrationForceGroups", stiffGroups, groups);
    Integrator::setIntegrationForceGroups(groups);
}

void StochasticImpulseIntegrator::setSplitting(Splitting newSplitting) {
    validateSplitting(newSplitting, friction, "splitting");
    validateSplitting(newSplitting, getStiffModeFriction(), "splitting");
    splitting = newSplitting;
}

void StochasticImpulseIntegrator::setThermostatPlacement(ThermostatPlacement placement) {
    if (placement != Throughout && placement != Middle)
        throwInvalidParameter(Owner, "thermostatPlacement", std::to_string((int)placement),
                              "thermostatPlacement must be StochasticImpulseIntegrator::Throughout (0) or "
                              "StochasticImpulseIntegrator::Middle (1)");
    thermostatPlacement = placement;
}

vector<double> StochasticImpulseIntegrator::getStiffModeFrequencies() {
    if (context == nullptr)
        throw OpenMMException(Owner + ": getStiffModeFrequencies() needs the integrator to be bound to a Context");
    return stepKernel->getStiffModeFrequencies(*context, *this, binding.stiffModesValid);
}

void StochasticImpulseIntegrator::updateStiffModes() {
    binding.stiffModesValid = false;
}

void StochasticImpulseIntegrator::initialize(ContextImpl& contextRef) {
    if (owner != nullptr && &contextRef.getOwner() != owner)
        throw OpenMMException("This Integrator is already bound to a context");
    requireForceInGroups(Owner, contextRef.getSystem(), stiffGroups);
    requireStiffGroupsIntegrated(Owner, "integrationForceGroups", stiffGroups, getIntegrationForceGroups());
    rejectConstraintsInsideStiffComponents(contextRef, bondedStiffComponents(contextRef, stiffGroups));
    context = &contextRef;
    owner = &contextRef.getOwner();
    stepKernel =
        &binding.create<IntegrateStochasticImpulseStepKernel>(contextRef, IntegrateStochasticImpulseStepKernel::Name());
    stepKernel->initialize(contextRef.getSystem(), *this);
    binding.bound(contextRef);
}

void StochasticImpulseIntegrator::cleanup() {
    stepKernel = nullptr;
    binding.release();
}

vector<string> StochasticImpulseIntegrator::getKernelNames() {
    return {IntegrateStochasticImpulseStepKernel::Name()};
}

void StochasticImpulseIntegrator::stateChanged(State::DataType changed) {
    if (context != nullptr)
        binding.stateChanged(*context, changed);
}

double StochasticImpulseIntegrator::computeKineticEnergy() {
    return stepKernel->computeKineticEnergy(*context, *this);
}

void StochasticImpulseIntegrator::step(int steps) {
    if (context == nullptr)
        throw OpenMMException("This Integrator is not bound to a context!");
    for (int i = 0; i < steps; ++i) {
        binding.beforeStep(*context);
        stepKernel->execute(*context, *this, binding.forcesValid, binding.stiffModesValid);
    }
    binding.afterSteps(*context, steps);
}

void StochasticImpulseIntegrator::createCheckpoint(std::ostream& stream) const {
    binding.createCheckpoint(*context, stream);
}

void StochasticImpulseIntegrator::loadCheckpoint(std::istream& stream) {
    binding.loadCheckpoint(*context, stream);
}

string StochasticImpulseIntegrator::describeStep() const {
    return describeSchedule(impulseSchedule(impulseParameters(*this)), stiffGroups, getIntegrationForceGroups(), "H",
                            "");
}

double StochasticImpulseIntegrator::getAcceptanceRate() const {
    return binding.getAcceptanceRate(Owner);
}

vector<Vec3> StochasticImpulseIntegrator::getVelocitiesForTemperature(const System& system, double temperature,
                                                                      int randomSeed) const {
    if (!hasStiffModeTemperature())
        return Integrator::getVelocitiesForTemperature(system, temperature, randomSeed);
    return velocitiesWithStiffTemperature(system, stiffGroups, temperature, stiffModeTemperature, randomSeed);
}

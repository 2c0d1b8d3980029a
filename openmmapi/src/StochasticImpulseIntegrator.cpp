#include "StochasticImpulseIntegrator.h"
#include "FlavorKernels.h"
#include "internal/ParameterChecks.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/Context.h"
#include "openmm/Force.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

namespace {

const string Owner = "StochasticImpulseIntegrator";

void requireSplittingAllowsFriction(StochasticImpulseIntegrator::Splitting splitting, double friction,
                                    const string& parameter) {
    if (splitting == StochasticImpulseIntegrator::Yoshida4 && friction != 0.0)
        throwInvalidParameter(Owner, parameter, parameter == "splitting" ? string("Yoshida4") : formatNumber(friction),
                              "the Yoshida4 splitting has a substep backwards in time and is defined only for friction "
                              "0 (friction is " +
                                  formatNumber(friction) + " 1/ps); use Strang or LieTrotter with friction");
}

} // namespace

StochasticImpulseIntegrator::StochasticImpulseIntegrator(double temperature, double frictionCoeff, double stepSize,
                                                         int stiffGroups)
    : temperature(0.0), friction(0.0), stiffModeTemperature(-1.0), stiffModeFriction(-1.0), stiffGroups(0),
      splitting(Strang), thermostatPlacement(Throughout), randomNumberSeed(0), forcesAreValid(false),
      stiffModesValid(false), stepKernel(nullptr) {
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
    requireSplittingAllowsFriction(splitting, coeff, "friction");
    friction = coeff;
}

void StochasticImpulseIntegrator::setStiffModeTemperature(double temp) {
    requireNonNegative(Owner, "stiffModeTemperature", temp, "K");
    stiffModeTemperature = temp;
}

void StochasticImpulseIntegrator::setStiffModeFriction(double coeff) {
    requireNonNegative(Owner, "stiffModeFriction", coeff, "1/ps");
    requireSplittingAllowsFriction(splitting, coeff, "stiffModeFriction");
    stiffModeFriction = coeff;
}

void StochasticImpulseIntegrator::setStiffGroups(int groups) {
    requireGroupMask(Owner, "stiffGroups", groups);
    if (context != nullptr) {
        requireForceInGroups(Owner, context->getSystem(), groups);
        requireStiffGroupsIntegrated(Owner, "stiffGroups", groups, getIntegrationForceGroups());
    }
    stiffGroups = groups;
    stiffModesValid = false;
}

void StochasticImpulseIntegrator::setIntegrationForceGroups(int groups) {
    if (context != nullptr)
        requireStiffGroupsIntegrated(Owner, "integrationForceGroups", stiffGroups, groups);
    Integrator::setIntegrationForceGroups(groups);
}

void StochasticImpulseIntegrator::setSplitting(Splitting newSplitting) {
    if (newSplitting != LieTrotter && newSplitting != Strang && newSplitting != Yoshida4 && newSplitting != Filtered &&
        newSplitting != Warped)
        throwInvalidParameter(Owner, "splitting", std::to_string((int)newSplitting),
                              "splitting must be LieTrotter (0), Strang (1), Yoshida4 (2), Filtered (3) or Warped (4)");
    requireSplittingAllowsFriction(newSplitting, friction, "splitting");
    requireSplittingAllowsFriction(newSplitting, getStiffModeFriction(), "splitting");
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
    return stepKernel->getStiffModeFrequencies(*context, *this, stiffModesValid);
}

void StochasticImpulseIntegrator::updateStiffModes() {
    stiffModesValid = false;
}

void StochasticImpulseIntegrator::initialize(ContextImpl& contextRef) {
    if (owner != nullptr && &contextRef.getOwner() != owner)
        throw OpenMMException("This Integrator is already bound to a context");
    requireForceInGroups(Owner, contextRef.getSystem(), stiffGroups);
    requireStiffGroupsIntegrated(Owner, "integrationForceGroups", stiffGroups, getIntegrationForceGroups());
    rejectConstraintsInsideStiffComponents(contextRef, bondedStiffComponents(contextRef, stiffGroups));
    context = &contextRef;
    owner = &contextRef.getOwner();
    kernel = context->getPlatform().createKernel(IntegrateStochasticImpulseStepKernel::Name(), contextRef);
    stepKernel = &kernel.getAs<IntegrateStochasticImpulseStepKernel>();
    stepKernel->initialize(contextRef.getSystem(), *this);
    stepKernel->saveContextState(contextRef, true);
    forcesAreValid = false;
    stiffModesValid = false;
}

void StochasticImpulseIntegrator::cleanup() {
    stepKernel = nullptr;
    kernel = Kernel();
}

vector<string> StochasticImpulseIntegrator::getKernelNames() {
    return {IntegrateStochasticImpulseStepKernel::Name()};
}

void StochasticImpulseIntegrator::stateChanged(State::DataType changed) {
    forcesAreValid = false;
    // Parameters: a context parameter changed.  Energy: a force's updateParametersInContext() (or a checkpoint).
    if (changed == State::Parameters || changed == State::Energy)
        stiffModesValid = false;
    if (stepKernel != nullptr && changed != State::Energy)
        stepKernel->saveContextState(*context, changed == State::Parameters);
    // A state set from outside starts the next step afresh, as the first one.
    if (stepKernel != nullptr && (changed == State::Positions || changed == State::Velocities))
        stepKernel->forgetStepHistory();
}

double StochasticImpulseIntegrator::computeKineticEnergy() {
    return stepKernel->computeKineticEnergy(*context, *this);
}

void StochasticImpulseIntegrator::step(int steps) {
    if (context == nullptr)
        throw OpenMMException("This Integrator is not bound to a context!");
    for (int i = 0; i < steps; ++i) {
        if (context->updateContextState())
            forcesAreValid = false;
        stepKernel->execute(*context, *this, forcesAreValid, stiffModesValid);
    }
    if (steps > 0)
        stepKernel->saveContextState(*context, false);
}

void StochasticImpulseIntegrator::createCheckpoint(std::ostream& stream) const {
    stepKernel->createCheckpoint(*context, stream);
}

void StochasticImpulseIntegrator::loadCheckpoint(std::istream& stream) {
    stepKernel->loadCheckpoint(*context, stream);
    forcesAreValid = false;
}

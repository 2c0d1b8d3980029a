#include "FlavorIntegrator.h"
#include "FlavorKernels.h"
#include "internal/FlowSchedule.h"
#include "internal/ParameterChecks.h"
#include "internal/StepKernelBinding.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/Context.h"
#include "openmm/Force.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

namespace {

const string Owner = "FlavorIntegrator";

/**
 * Throws, naming parameter, unless a force of the System is soft (in an integration force group and not stiff).  A
 * FLAVOR without soft forces averages nothing; it almost always comes from a bitmask mistaken for a group number.
 */
void requireSoftForce(const System& system, const string& parameter, int stiffGroups, int integrationGroups) {
    for (int i = 0; i < system.getNumForces(); ++i) {
        const int group = 1 << system.getForce(i).getForceGroup();
        if ((group & integrationGroups) != 0 && (group & stiffGroups) == 0)
            return;
    }
    throwInvalidParameter(
        Owner, parameter, std::to_string(parameter == "stiffGroups" ? stiffGroups : integrationGroups),
        "no force of the System is soft: every force in the integration force groups " +
            describeGroups(integrationGroups) + " is in the stiff groups " + describeGroups(stiffGroups) +
            " (stiffGroups = " + std::to_string(stiffGroups) +
            "), so FLAVOR has nothing to average.  stiffGroups is a bitmask: 1 means group 0, 2 = 1<<1 means group 1 "
            "(in Python, {1} means group 1); put the soft forces in other groups (Force.setForceGroup)");
}

/** Throws, naming the parameter, unless the Context has a global parameter name (or name is empty). */
void requireClockParameter(const ContextImpl& context, const string& name) {
    if (name.empty() || context.getParameters().count(name) != 0)
        return;
    string known;
    for (const auto& parameter : context.getParameters())
        known += (known.empty() ? "" : ", ") + parameter.first;
    throwInvalidParameter(Owner, "stiffClockParameter", "\"" + name + "\"",
                          "the Context has no global parameter \"" + name +
                              "\" (its global parameters: " + (known.empty() ? string("none") : known) +
                              "); define it in the stiff force (e.g. addGlobalParameter of a Custom force)");
}

} // namespace

FlavorIntegrator::FlavorIntegrator(double mesoStep, double microStep, int stiffGroups)
    : microStep(0.0), stiffGroups(0), scheme(Verlet), averaging(Nonintrusive), exactFastFlow(false),
      thermostatPlacement(Edges), temperature(0.0), friction(0.0), stiffFriction(false), randomNumberSeed(0),
      stepKernel(nullptr) {
    requirePositive(Owner, "mesoStep", mesoStep, "ps");
    requirePositive(Owner, "microStep", microStep, "ps");
    if (microStep > mesoStep)
        throwInvalidParameter(Owner, "microStep", formatNumber(microStep),
                              "microStep must be > 0 and <= mesoStep (" + formatNumber(mesoStep) + " ps)");
    requireGroupMask(Owner, "stiffGroups", stiffGroups);
    Integrator::setStepSize(mesoStep);
    this->microStep = microStep;
    this->stiffGroups = stiffGroups;
    setConstraintTolerance(1e-5);
}

void FlavorIntegrator::setMesoStep(double size) {
    requirePositive(Owner, "mesoStep", size, "ps");
    if (size < microStep)
        throwInvalidParameter(Owner, "mesoStep", formatNumber(size),
                              "mesoStep must be >= microStep (" + formatNumber(microStep) + " ps)");
    Integrator::setStepSize(size);
}

void FlavorIntegrator::setStepSize(double size) {
    setMesoStep(size);
}

void FlavorIntegrator::setMicroStep(double size) {
    requirePositive(Owner, "microStep", size, "ps");
    if (size > getMesoStep())
        throwInvalidParameter(Owner, "microStep", formatNumber(size),
                              "microStep must be > 0 and <= mesoStep (" + formatNumber(getMesoStep()) + " ps)");
    microStep = size;
}

void FlavorIntegrator::setStiffGroups(int groups) {
    requireGroupMask(Owner, "stiffGroups", groups);
    if (context != nullptr) {
        requireForceInGroups(Owner, context->getSystem(), groups);
        requireStiffGroupsIntegrated(Owner, "stiffGroups", groups, getIntegrationForceGroups());
        requireSoftForce(context->getSystem(), "stiffGroups", groups, getIntegrationForceGroups());
        if (averaging != Nonintrusive)
            rejectUnfreezableStiffForces(context->getSystem(), groups, !frozenDistances.empty());
    }
    stiffGroups = groups;
    binding.stiffModesValid = false;
}

void FlavorIntegrator::setIntegrationForceGroups(int groups) {
    if (context != nullptr) {
        requireStiffGroupsIntegrated(Owner, "integrationForceGroups", stiffGroups, groups);
        requireSoftForce(context->getSystem(), "integrationForceGroups", stiffGroups, groups);
    }
    Integrator::setIntegrationForceGroups(groups);
}

void FlavorIntegrator::setScheme(Scheme newScheme) {
    if (newScheme != SymplecticEuler && newScheme != Verlet)
        throwInvalidParameter(Owner, "scheme", std::to_string((int)newScheme),
                              "scheme must be FlavorIntegrator::SymplecticEuler (0) or FlavorIntegrator::Verlet (1)");
    scheme = newScheme;
}

void FlavorIntegrator::setAveraging(Averaging newAveraging) {
    if (newAveraging != Nonintrusive && newAveraging != Artificial && newAveraging != ArtificialProjected)
        throwInvalidParameter(Owner, "averaging", std::to_string((int)newAveraging),
                              "averaging must be FlavorIntegrator::Nonintrusive (0), FlavorIntegrator::Artificial (1) "
                              "or FlavorIntegrator::ArtificialProjected (2)");
    if (context != nullptr && newAveraging != Nonintrusive)
        rejectUnfreezableStiffForces(context->getSystem(), stiffGroups, !frozenDistances.empty());
    averaging = newAveraging;
}

void FlavorIntegrator::setExactFastFlow(bool exact) {
    exactFastFlow = exact;
}

void FlavorIntegrator::setThermostatPlacement(ThermostatPlacement placement) {
    if (placement != Edges && placement != Middle)
        throwInvalidParameter(
            Owner, "thermostatPlacement", std::to_string((int)placement),
            "thermostatPlacement must be FlavorIntegrator::Edges (0) or FlavorIntegrator::Middle (1)");
    thermostatPlacement = placement;
}

int FlavorIntegrator::addFrozenDistance(int particle1, int particle2) {
    const int numParticles = context == nullptr ? -1 : context->getSystem().getNumParticles();
    for (int p : {particle1, particle2})
        if (p < 0 || (numParticles >= 0 && p >= numParticles))
            throwInvalidParameter(Owner, "frozen distance particle", std::to_string(p),
                                  "particle indices must be >= 0" +
                                      (numParticles >= 0
                                           ? " and < " + std::to_string(numParticles) + " (the number of particles)"
                                           : string()));
    if (particle1 == particle2)
        throwInvalidParameter(Owner, "frozen distance particles",
                              std::to_string(particle1) + ", " + std::to_string(particle2),
                              "the two particles of a frozen distance must differ");
    frozenDistances.emplace_back(particle1, particle2);
    binding.stiffModesValid = false;
    return (int)frozenDistances.size() - 1;
}

void FlavorIntegrator::getFrozenDistance(int index, int& particle1, int& particle2) const {
    if (index < 0 || index >= (int)frozenDistances.size())
        throwInvalidParameter(Owner, "index", std::to_string(index),
                              "index must be >= 0 and < " + std::to_string(frozenDistances.size()) +
                                  " (the number of frozen distances)");
    particle1 = frozenDistances[index].first;
    particle2 = frozenDistances[index].second;
}

void FlavorIntegrator::setStiffClockParameter(const string& name) {
    if (context != nullptr)
        requireClockParameter(*context, name);
    stiffClockParameter = name;
}

void FlavorIntegrator::setTemperature(double temp) {
    requireNonNegative(Owner, "temperature", temp, "K");
    temperature = temp;
}

void FlavorIntegrator::setFriction(double coeff) {
    requireNonNegative(Owner, "friction", coeff, "1/ps");
    friction = coeff;
}

void FlavorIntegrator::setStiffFriction(bool stiff) {
    stiffFriction = stiff;
}

namespace {

void requireParticleIndices(const vector<int>& particles, int numParticles) {
    for (int p : particles)
        if (p < 0 || (numParticles >= 0 && p >= numParticles))
            throwInvalidParameter(Owner, "frictionParticles", "[..., " + std::to_string(p) + ", ...]",
                                  "particle indices must be >= 0" +
                                      (numParticles >= 0
                                           ? " and < " + std::to_string(numParticles) + " (the number of particles)"
                                           : string()));
    vector<int> sorted = particles;
    std::sort(sorted.begin(), sorted.end());
    auto repeated = std::adjacent_find(sorted.begin(), sorted.end());
    if (repeated != sorted.end())
        throwInvalidParameter(Owner, "frictionParticles", "[..., " + std::to_string(*repeated) + ", ...]",
                              "particle " + std::to_string(*repeated) +
                                  " is listed more than once; each particle may appear at most once");
}

} // namespace

void FlavorIntegrator::setFrictionParticles(const vector<int>& particles) {
    requireParticleIndices(particles, context == nullptr ? -1 : context->getSystem().getNumParticles());
    frictionParticles = particles;
}

void FlavorIntegrator::initialize(ContextImpl& contextRef) {
    if (owner != nullptr && &contextRef.getOwner() != owner)
        throw OpenMMException("This Integrator is already bound to a context");
    requireForceInGroups(Owner, contextRef.getSystem(), stiffGroups);
    requireStiffGroupsIntegrated(Owner, "integrationForceGroups", stiffGroups, getIntegrationForceGroups());
    requireSoftForce(contextRef.getSystem(), "stiffGroups", stiffGroups, getIntegrationForceGroups());
    requireParticleIndices(frictionParticles, contextRef.getSystem().getNumParticles());
    requireClockParameter(contextRef, stiffClockParameter);
    if (averaging != Nonintrusive)
        rejectUnfreezableStiffForces(contextRef.getSystem(), stiffGroups, !frozenDistances.empty());
    for (const std::pair<int, int>& pair : frozenDistances)
        for (int p : {pair.first, pair.second})
            if (p >= contextRef.getSystem().getNumParticles())
                throwInvalidParameter(Owner, "frozen distance particle", std::to_string(p),
                                      "particle indices must be < " +
                                          std::to_string(contextRef.getSystem().getNumParticles()) +
                                          " (the number of particles)");
    context = &contextRef;
    owner = &contextRef.getOwner();
    stepKernel = &binding.create<IntegrateFlavorStepKernel>(contextRef, IntegrateFlavorStepKernel::Name());
    stepKernel->initialize(contextRef.getSystem(), *this);
    binding.bound(contextRef);
}

void FlavorIntegrator::cleanup() {
    stepKernel = nullptr;
    binding.release();
}

vector<string> FlavorIntegrator::getKernelNames() {
    return {IntegrateFlavorStepKernel::Name()};
}

void FlavorIntegrator::stateChanged(State::DataType changed) {
    if (context != nullptr)
        binding.stateChanged(*context, changed);
}

double FlavorIntegrator::computeKineticEnergy() {
    return stepKernel->computeKineticEnergy(*context, *this);
}

void FlavorIntegrator::step(int steps) {
    if (context == nullptr)
        throw OpenMMException("This Integrator is not bound to a context!");
    for (int i = 0; i < steps; ++i) {
        binding.beforeStep(*context);
        stepKernel->execute(*context, *this, binding.forcesValid, binding.stiffModesValid);
    }
    binding.afterSteps(*context, steps);
}

void FlavorIntegrator::createCheckpoint(std::ostream& stream) const {
    binding.createCheckpoint(*context, stream);
}

void FlavorIntegrator::loadCheckpoint(std::istream& stream) {
    binding.loadCheckpoint(*context, stream);
}

string FlavorIntegrator::describeStep() const {
    FlavorParameters parameters = flavorParameters(*this);
    parameters.frozen =
        stepKernel != nullptr ? (SubFlow::FrozenSet)stepKernel->getFrozenSet() : SubFlow::FrozenSet::None;
    return describeSchedule(flavorSchedule(parameters), stiffGroups, getIntegrationForceGroups(), "δ", "τ",
                            stepKernel != nullptr ? stepKernel->getNumFrozen() : 0);
}

double FlavorIntegrator::getAcceptanceRate() const {
    return binding.getAcceptanceRate(Owner);
}

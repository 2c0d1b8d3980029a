#include "StepControl.h"
#include "ConstraintProjector.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

void FlavorPlugin::rejectUnsupported(const Schedule& schedule, const StepBackend& backend, const string& owner,
                                     const string& platformName, const std::function<string(SubFlow::Kind)>& setting) {
    for (const SubFlow& flow : schedule)
        if (!backend.supports(flow.kind))
            throw OpenMMException(owner + " on the " + platformName + " platform: " + setting(flow.kind) +
                                  " is not supported there yet; set it to false, or use the Reference or CPU "
                                  "platform");
}

FlavorStepControl::FlavorStepControl(const System& system, StepBackend& backend, string platformName)
    : backend(backend), platformName(std::move(platformName)), frozen(system) {}

void FlavorStepControl::check(const FlavorParameters& current, bool constrained) const {
    validateFlavorStep(current);
    validateMetropolis(current, constrained);
    rejectUnsupported(flavorSchedule(current), backend, "FlavorIntegrator", platformName, [](SubFlow::Kind) {
        return string("the Metropolis adjustment (FlavorIntegrator::setMetropolis(true))");
    });
}

void FlavorStepControl::step(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                             bool& stiffModesValid) {
    const bool constrained = context.getSystem().getNumConstraints() > 0;
    FlavorParameters current = flavorParameters(integrator);
    current.frozen = frozen.getScheduledSet();
    const string& clock = integrator.getStiffClockParameter();
    bool changed = !configured || !(current == parameters) || clock != clockParameter;
    // Checked before anything is decided from them, and only when a setting changed.
    if (changed)
        check(current, constrained);
    // What the artificial averagings freeze is decided where the first step starts and after anything that may
    // change it (FrozenCoordinates).
    if (current.averaging != FlavorIntegrator::Nonintrusive &&
        (!stiffModesValid || frozen.getFrozenSet() == SubFlow::FrozenSet::None)) {
        if (frozen.determine(context, integrator, current))
            backend.setFrozenCoordinates(frozen.getDistances() ? nullptr : frozen.getModes(), frozen.getDistances());
        stiffModesValid = true;
        const SubFlow::FrozenSet scheduled = frozen.getScheduledSet();
        if (scheduled != current.frozen) {
            current.frozen = scheduled;
            check(current, constrained);
            changed = true;
        }
    }
    if (changed || !(current == parameters)) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        backend.setSchedule(flavorSchedule(current));
        backend.setStiffClock(clock, current.microStep, current.mesoStep);
        parameters = current;
        clockParameter = clock;
        configured = true;
    }
    backend.setFrictionParticles(integrator.getFrictionParticles());
    backend.step(context, integrator.getConstraintTolerance(), integrator.getMesoStep(), forcesValid);
}

ImpulseStepControl::ImpulseStepControl(const System& system, StepBackend& backend, string platformName)
    : backend(backend), platformName(std::move(platformName)),
      measurement(system, "StochasticImpulseIntegrator", "use FlavorIntegrator for nonlinear stiff forces") {}

void ImpulseStepControl::check(const ImpulseParameters& current, bool constrained) const {
    validateImpulseStep(current);
    validateMetropolis(current, constrained);
    rejectUnsupported(impulseSchedule(current), backend, "StochasticImpulseIntegrator", platformName,
                      [](SubFlow::Kind) {
                          return string("the Metropolis adjustment (StochasticImpulseIntegrator::setMetropolis(true))");
                      });
}

void ImpulseStepControl::measureStiffModes(ContextImpl& context, int stiffGroups) {
    // Constraints may join a stiff component to particles outside it: the constrained particle carries its component
    // through the constraint solve.
    auto checkConstraints = [&context](const StiffModes& modes) {
        ConstraintProjector::rejectUncarriedConstraints(context, modes);
    };
    if (measurement.measure(context, stiffGroups, checkConstraints))
        backend.setStiffModes(measurement.getModes());
}

ImpulseParameters ImpulseStepControl::scheduled() const {
    ImpulseParameters p = parameters;
    // A limit of π binds no mode (setMaxWarpedPhase(π): Warped's own step; or nothing couples).
    if (choosesPhase(p) && phaseChosen)
        p.maxWarpedPhase = choice.phase;
    if (p.maxWarpedPhase >= M_PI)
        p.maxWarpedPhase = 0.0;
    return p;
}

void ImpulseStepControl::choosePhase(ContextImpl& context, const ImpulseParameters& p) {
    choice = chooseWarpedPhase(context, *measurement.getModes(), ~p.stiffGroups & p.integrationGroups);
}

void ImpulseStepControl::step(ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                              bool& stiffModesValid) {
    const ImpulseParameters current = impulseParameters(integrator);
    bool rebuild = false;
    if (!configured || !(current == parameters)) {
        check(current, context.getSystem().getNumConstraints() > 0);
        parameters = current;
        configured = true;
        rebuild = true;
        // Chosen again for the new settings (the soft groups may have changed).
        phaseChosen = false;
    }
    // Rebuilt only when a parameter or the chosen limit changed, so the step loop does not allocate.
    auto schedule = [this]() {
        backend.setSchedule(impulseSchedule(scheduled()));
        scheduledPhase = scheduled().maxWarpedPhase;
    };
    if (rebuild)
        schedule();
    bool measured = false;
    if (!stiffModesValid || !measurement.getModes()) {
        measureStiffModes(context, parameters.stiffGroups);
        stiffModesValid = true;
        measured = true;
    }
    if (choosesPhase(parameters) && (measured || !phaseChosen)) {
        choosePhase(context, parameters);
        phaseChosen = true;
        if (scheduled().maxWarpedPhase != scheduledPhase)
            schedule();
    }
    backend.step(context, integrator.getConstraintTolerance(), parameters.stepSize, forcesValid);
}

const WarpedPhaseChoice* ImpulseStepControl::getWarpedPhaseChoice(ContextImpl& context,
                                                                  const StochasticImpulseIntegrator& integrator,
                                                                  bool& stiffModesValid) {
    const ImpulseParameters current = impulseParameters(integrator);
    if (!choosesPhase(current))
        return nullptr;
    if (!stiffModesValid || !measurement.getModes()) {
        measureStiffModes(context, current.stiffGroups);
        stiffModesValid = true;
        phaseChosen = false;
    }
    // Without a step taken yet the choice is made for these settings; the step keeps it unless they change.
    if (!phaseChosen || !(current == parameters)) {
        choosePhase(context, current);
        phaseChosen = current == parameters;
    }
    return &choice;
}

vector<double> ImpulseStepControl::getStiffModeFrequencies(ContextImpl& context, int stiffGroups,
                                                           bool& stiffModesValid) {
    if (!stiffModesValid || !measurement.getModes()) {
        measureStiffModes(context, stiffGroups);
        stiffModesValid = true;
    }
    return measurement.getModes()->getStiffFrequencies();
}

#ifndef OPENMM_FLAVORS_STEP_CONTROL_H_
#define OPENMM_FLAVORS_STEP_CONTROL_H_

#include "FlavorIntegrator.h"
#include "FrozenCoordinates.h"
#include "StepBackend.h"
#include "StiffProbe.h"
#include "StochasticImpulseIntegrator.h"
#include "WarpedPhaseChoice.h"
#include "internal/FlowSchedule.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include <functional>
#include <string>
#include <vector>

namespace FlavorPlugin {

/**
 * The step of a FlavorIntegrator on every platform: reads the integrator's parameters, checks them and sets the
 * backend's schedule and stiff clock only when one changed (a rejected setting leaves the last accepted one in place,
 * and the next step checks again), decides what the artificial averagings freeze where the first step starts and
 * after anything that may change it, and takes the step on the backend.
 */
class OPENMM_EXPORT_FLAVORS FlavorStepControl {
public:
    /** platformName names the platform where the backend does not support a setting. */
    FlavorStepControl(const OpenMM::System& system, StepBackend& backend, std::string platformName);
    void step(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
              bool& stiffModesValid);
    const FrozenCoordinates& getFrozenCoordinates() const { return frozen; }

private:
    /** Throws unless the parameters are valid for the System and the backend supports their schedule. */
    void check(const FlavorParameters& current, bool constrained) const;
    StepBackend& backend;
    std::string platformName;
    FrozenCoordinates frozen;
    bool configured = false;
    FlavorParameters parameters;
    std::string clockParameter;
};

/**
 * The step of a StochasticImpulseIntegrator on every platform: parameters checked and applied only when one changed,
 * the stiff modes measured where the first step starts and after anything that may change them, the Warped phase
 * limit chosen from the System with them unless the integrator sets one (WarpedPhaseChoice), then the backend's step.
 */
class OPENMM_EXPORT_FLAVORS ImpulseStepControl {
public:
    ImpulseStepControl(const OpenMM::System& system, StepBackend& backend, std::string platformName);
    void step(OpenMM::ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
              bool& stiffModesValid);
    /** The stiff modes' frequencies (measured first if they are not valid). */
    std::vector<double> getStiffModeFrequencies(OpenMM::ContextImpl& context, int stiffGroups, bool& stiffModesValid);
    /**
     * The Warped phase limit chosen for the integrator's settings (the stiff modes measured and the limit chosen first
     * if needed), or null where the integrator chooses none: another splitting, or a limit of its own.
     */
    const WarpedPhaseChoice* getWarpedPhaseChoice(OpenMM::ContextImpl& context,
                                                  const StochasticImpulseIntegrator& integrator, bool& stiffModesValid);

private:
    void check(const ImpulseParameters& current, bool constrained) const;
    void measureStiffModes(OpenMM::ContextImpl& context, int stiffGroups);
    /** Whether these settings leave the Warped phase limit to the integrator. */
    static bool choosesPhase(const ImpulseParameters& p) {
        return p.splitting == StochasticImpulseIntegrator::Warped && p.maxWarpedPhase == 0.0;
    }
    /** The parameters the schedule is built from: the chosen phase limit in place of 0 where there is one. */
    ImpulseParameters scheduled() const;
    /** Chooses the phase limit for the current modes and positions, with the soft forces of p. */
    void choosePhase(OpenMM::ContextImpl& context, const ImpulseParameters& p);
    StepBackend& backend;
    std::string platformName;
    StiffModesMeasurement measurement;
    bool configured = false;
    ImpulseParameters parameters;
    // The limit chosen for the modes last measured (phaseChosen), the phase the schedule was built with.
    WarpedPhaseChoice choice;
    bool phaseChosen = false;
    double scheduledPhase = 0.0;
};

/**
 * Throws, naming the setting, where a schedule holds a sub-flow the backend does not support; setting names the
 * integrator's setter that asks for a kind.
 */
OPENMM_EXPORT_FLAVORS void rejectUnsupported(const Schedule& schedule, const StepBackend& backend,
                                             const std::string& owner, const std::string& platformName,
                                             const std::function<std::string(SubFlow::Kind)>& setting);

} // namespace FlavorPlugin

#endif

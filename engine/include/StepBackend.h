#ifndef OPENMM_FLAVORS_STEP_BACKEND_H_
#define OPENMM_FLAVORS_STEP_BACKEND_H_

#include "FrozenDistances.h"
#include "StiffModes.h"
#include "internal/FlowSchedule.h"
#include <memory>
#include <string>
#include <vector>

namespace OpenMM {
class ContextImpl;
} // namespace OpenMM

namespace FlavorPlugin {

/**
 * What the step controllers (FlavorStepControl, ImpulseStepControl) drive: the engine that executes the passes of a
 * step on one platform's particle data, FlowStepRunner on the Reference and CPU platforms and CommonFlowStepper on
 * OpenMM's compute platforms.  The controllers own the parameters, their checks, the frozen coordinates and stiff
 * modes; a backend executes what they set.
 */
class StepBackend {
public:
    virtual ~StepBackend() = default;
    /** Whether the backend has an executor for sub-flows of this kind (the controllers reject the others by name). */
    virtual bool supports(SubFlow::Kind kind) const = 0;
    /** Sets the schedule of one step; cheap when nothing changed. */
    virtual void setSchedule(const Schedule& schedule) = 0;
    /** Sets the decomposed stiff potential of the exact stiff flows. */
    virtual void setStiffModes(std::shared_ptr<const StiffModes> modes) = 0;
    /** Sets what FrozenDrift and FrozenKick hold: the nonzero modes of frozenModes, or the distances (one null). */
    virtual void setFrozenCoordinates(std::shared_ptr<const StiffModes> frozenModes,
                                      std::shared_ptr<FrozenDistances> distances) = 0;
    /** Restricts the thermostats to the given particles; an empty list means every particle. */
    virtual void setFrictionParticles(const std::vector<int>& particles) = 0;
    /** Runs the clocked kicks on the stiff clock (FlavorIntegrator::setStiffClockParameter). */
    virtual void setStiffClock(const std::string& parameter, double microStep, double mesoStep) = 0;
    /** Takes one step and advances the Context's time by stepSize and its step count by one. */
    virtual void step(OpenMM::ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid) = 0;
};

} // namespace FlavorPlugin

#endif

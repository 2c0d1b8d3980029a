#ifndef OPENMM_FLAVORS_STEP_KERNEL_BINDING_H_
#define OPENMM_FLAVORS_STEP_KERNEL_BINDING_H_

#include "openmm/Kernel.h"
#include "openmm/State.h"
#include "windowsExportFlavors.h"
#include <iosfwd>
#include <string>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

class FlowStepKernel;

/**
 * How both integrators keep their step kernel in step with the Context, in one place: creating it, what a change of
 * the Context's state invalidates, the step loop's bookkeeping and checkpoints.  The integrators differ only in what
 * they check before binding and in the kernel's execute().
 */
class OPENMM_EXPORT_FLAVORS StepKernelBinding {
public:
    /** Creates the kernel named name on the Context's platform and returns it, already cast to its interface. */
    /** (Instantiated where FlavorKernels.h is included.) */
    template <class KernelInterface> KernelInterface& create(OpenMM::ContextImpl& context, const std::string& name) {
        kernel = createKernel(context, name);
        KernelInterface& typed = kernel.getAs<KernelInterface>();
        stepKernel = &typed;
        return typed;
    }
    /** The kernel was initialized: remember the Context's state; forces and stiff modes are not known yet. */
    void bound(OpenMM::ContextImpl& context);
    void release();
    /**
     * The Context's state changed from outside: forces are out of date; a parameter or a force's parameters may
     * change the stiff modes; positions or velocities set from outside start the next step afresh, as the first one
     * (the step history is forgotten).  The kernel remembers the new state for a failed checkpoint load.
     */
    void stateChanged(OpenMM::ContextImpl& context, OpenMM::State::DataType changed);
    /** Before each step: a force whose parameters changed (updateContextState()) invalidates the cached forces. */
    void beforeStep(OpenMM::ContextImpl& context);
    /** After a call of step(steps): remember the Context's state for a failed checkpoint load. */
    void afterSteps(OpenMM::ContextImpl& context, int steps);
    void createCheckpoint(OpenMM::ContextImpl& context, std::ostream& stream) const;
    /**
     * The fraction of Metropolis-adjusted proposals accepted since the kernel was created, NaN if none was made; owner
     * names the integrator in the exception thrown when no kernel is bound.
     */
    double getAcceptanceRate(const std::string& owner) const;
    /**
     * Loads the kernel's part of a checkpoint.  The stiff modes stay as measured: the continuation from the checkpoint
     * is then the one the Context had, bit for bit (a new Context measures them where its first step starts).
     */
    void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream);
    /** Whether cached forces may be reused, and whether the measured stiff modes are current. */
    bool forcesValid = false, stiffModesValid = false;

private:
    static OpenMM::Kernel createKernel(OpenMM::ContextImpl& context, const std::string& name);
    OpenMM::Kernel kernel;
    // The kernel's implementation, looked up once (Kernel::getAs() costs a dynamic_cast per call).
    FlowStepKernel* stepKernel = nullptr;
};

} // namespace FlavorPlugin

#endif

#ifndef OPENMM_FLAVORS_KERNELS_H_
#define OPENMM_FLAVORS_KERNELS_H_

#include "FlavorIntegrator.h"
#include "StochasticImpulseIntegrator.h"
#include "openmm/KernelImpl.h"
#include "openmm/System.h"
#include <iosfwd>
#include <string>
#include <vector>

namespace FlavorPlugin {

/**
 * What the step kernels of both integrators share: their part of a checkpoint, the Context state a failed load puts
 * back, and the step history (StepKernelBinding calls these the same way for both).
 */
class FlowStepKernel : public OpenMM::KernelImpl {
public:
    FlowStepKernel(std::string name, const OpenMM::Platform& platform) : OpenMM::KernelImpl(name, platform) {}
    /**
     * Write the kernel's state (random streams, step history) to a checkpoint.
     */
    virtual void createCheckpoint(OpenMM::ContextImpl& context, std::ostream& stream) const = 0;
    /**
     * Restore the kernel's state from a checkpoint.  If the stream holds no state of this integrator (another
     * integrator's checkpoint, another format version, a truncated one), put back the Context's state saved by
     * saveContextState(), leave the kernel's state as it was and throw an OpenMMException.
     */
    virtual void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream) = 0;
    /**
     * Remember the Context's positions, velocities, periodic box, time and step count (and its parameters when
     * withParameters is true) for a failed loadCheckpoint() to put back: OpenMM overwrites them from the checkpoint
     * before the integrator reads its part.
     */
    virtual void saveContextState(OpenMM::ContextImpl& context, bool withParameters) = 0;
    /**
     * Forget what the next step would take from the last one (velocity processing): the Context's
     * positions or velocities were set.
     */
    virtual void forgetStepHistory() = 0;
    /**
     * Get how many Metropolis-adjusted steps were proposed since the kernel was created, and how many accepted.
     */
    virtual void getProposalCounts(long long& proposed, long long& accepted) const = 0;
};

/**
 * This kernel is invoked by FlavorIntegrator to take one mesostep.
 */
class IntegrateFlavorStepKernel : public FlowStepKernel {
public:
    static std::string Name() { return "IntegrateFlavorStep"; }
    IntegrateFlavorStepKernel(std::string name, const OpenMM::Platform& platform) : FlowStepKernel(name, platform) {}
    /**
     * Initialize the kernel.
     *
     * @param system     the System this kernel will be applied to
     * @param integrator the FlavorIntegrator this kernel will be used for
     */
    virtual void initialize(const OpenMM::System& system, const FlavorIntegrator& integrator) = 0;
    /**
     * Execute the kernel.
     *
     * @param context      the context in which to execute this kernel
     * @param integrator   the FlavorIntegrator this kernel is being used for
     * @param forcesValid  whether forces cached by an earlier step are still valid; true on return
     * @param stiffModesValid  whether the measured stiff potential (used by the artificial averagings) is still
     *                     valid; true on return
     */
    virtual void execute(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                         bool& stiffModesValid) = 0;
    /**
     * Compute the kinetic energy.
     */
    virtual double computeKineticEnergy(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator) = 0;
    /**
     * Whether the artificial averagings freeze the stiff modes of a quadratic stiff group or the stiff bonded
     * distances (None until the first step has measured it).
     */
    virtual int getFrozenSet() const = 0;
    /** How many distances or stiff modes the artificial averagings freeze (0 until the first step has measured it). */
    virtual int getNumFrozen() const = 0;
};

/**
 * This kernel is invoked by StochasticImpulseIntegrator to take one step.
 */
class IntegrateStochasticImpulseStepKernel : public FlowStepKernel {
public:
    static std::string Name() { return "IntegrateStochasticImpulseStep"; }
    IntegrateStochasticImpulseStepKernel(std::string name, const OpenMM::Platform& platform)
        : FlowStepKernel(name, platform) {}
    /**
     * Initialize the kernel.
     *
     * @param system     the System this kernel will be applied to
     * @param integrator the StochasticImpulseIntegrator this kernel will be used for
     */
    virtual void initialize(const OpenMM::System& system, const StochasticImpulseIntegrator& integrator) = 0;
    /**
     * Execute the kernel.
     *
     * @param context          the context in which to execute this kernel
     * @param integrator       the integrator this kernel is being used for
     * @param forcesValid      whether forces cached by an earlier step are still valid; true on return
     * @param stiffModesValid  whether the measured stiff potential is still valid; true on return
     */
    virtual void execute(OpenMM::ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                         bool& stiffModesValid) = 0;
    /**
     * Get the angular frequencies of the stiff modes, measuring the stiff potential if needed.
     */
    virtual std::vector<double> getStiffModeFrequencies(OpenMM::ContextImpl& context,
                                                        const StochasticImpulseIntegrator& integrator,
                                                        bool& stiffModesValid) = 0;
    /**
     * Get the Warped phase limit the integrator chooses from the System (StochasticImpulseIntegrator::
     * setMaxWarpedPhase(0)), measuring the stiff potential and choosing first if needed: the phase, the largest soft
     * stiffness along the stiff modes in units of their own, and the seconds the choice took; empty where the
     * integrator chooses none (another splitting, or a limit set).
     */
    virtual std::vector<double> getWarpedPhaseChoice(OpenMM::ContextImpl& context,
                                                     const StochasticImpulseIntegrator& integrator,
                                                     bool& stiffModesValid) = 0;
    /**
     * Compute the kinetic energy.
     */
    virtual double computeKineticEnergy(OpenMM::ContextImpl& context,
                                        const StochasticImpulseIntegrator& integrator) = 0;
};

} // namespace FlavorPlugin

#endif

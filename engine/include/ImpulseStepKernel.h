#ifndef OPENMM_FLAVORS_IMPULSE_STEP_KERNEL_H_
#define OPENMM_FLAVORS_IMPULSE_STEP_KERNEL_H_

#include "FlavorKernels.h"
#include "FlowStepRunner.h"
#include "RunnerKernel.h"
#include "StepControl.h"
#include "StiffModes.h"
#include "StiffProbe.h"
#include "internal/windowsExportFlavors.h"
#include <memory>

namespace FlavorPlugin {

/**
 * The StochasticImpulseIntegrator kernel of every platform whose particle data is ReferencePlatform::PlatformData:
 * the platforms differ only in the ParallelLoop they supply.
 */
class OPENMM_EXPORT_FLAVORS ImpulseStepKernel : public RunnerKernel<IntegrateStochasticImpulseStepKernel> {
public:
    ImpulseStepKernel(std::string name, const OpenMM::Platform& platform, std::unique_ptr<ParallelLoop> loop);
    void initialize(const OpenMM::System& system, const StochasticImpulseIntegrator& integrator) override;
    void execute(OpenMM::ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                 bool& stiffModesValid) override;
    std::vector<double> getStiffModeFrequencies(OpenMM::ContextImpl& context,
                                                const StochasticImpulseIntegrator& integrator,
                                                bool& stiffModesValid) override;
    std::vector<double> getWarpedPhaseChoice(OpenMM::ContextImpl& context,
                                             const StochasticImpulseIntegrator& integrator,
                                             bool& stiffModesValid) override;
    double computeKineticEnergy(OpenMM::ContextImpl& context, const StochasticImpulseIntegrator& integrator) override;

private:
    std::unique_ptr<ParallelLoop> loop;
    std::unique_ptr<ImpulseStepControl> control;
};

} // namespace FlavorPlugin

#endif

#ifndef OPENMM_FLAVORS_FLAVOR_STEP_KERNEL_H_
#define OPENMM_FLAVORS_FLAVOR_STEP_KERNEL_H_

#include "FlavorKernels.h"
#include "FlowStepRunner.h"
#include "FrozenCoordinates.h"
#include "RunnerKernel.h"
#include "StepControl.h"
#include "internal/windowsExportFlavors.h"
#include <memory>

namespace FlavorPlugin {

/**
 * The FlavorIntegrator kernel of every platform whose particle data is ReferencePlatform::PlatformData: the
 * platforms differ only in the ParallelLoop they supply.
 */
class OPENMM_EXPORT_FLAVORS FlavorStepKernel : public RunnerKernel<IntegrateFlavorStepKernel> {
public:
    FlavorStepKernel(std::string name, const OpenMM::Platform& platform, std::unique_ptr<ParallelLoop> loop);
    void initialize(const OpenMM::System& system, const FlavorIntegrator& integrator) override;
    void execute(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                 bool& stiffModesValid) override;
    double computeKineticEnergy(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator) override;
    int getFrozenSet() const override;
    int getNumFrozen() const override;

private:
    std::unique_ptr<ParallelLoop> loop;
    std::unique_ptr<FlavorStepControl> control;
};

} // namespace FlavorPlugin

#endif

#ifndef OPENMM_FLAVORS_FLAVOR_STEP_KERNEL_H_
#define OPENMM_FLAVORS_FLAVOR_STEP_KERNEL_H_

#include "FlavorKernels.h"
#include "FlowStepRunner.h"
#include "RunnerKernel.h"
#include "StiffProbe.h"
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
    /**
     * Decides what the artificial averagings freeze: the nonzero modes of a quadratic stiff group, or the distances
     * of the stiff bonded forces and those added with FlavorIntegrator::addFrozenDistance().
     */
    void determineFrozenCoordinates(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator,
                                    const FlavorParameters& current);
    std::unique_ptr<ParallelLoop> loop;
    std::unique_ptr<StiffModesMeasurement> measurement;
    std::shared_ptr<FrozenDistances> frozenDistances;
    std::vector<std::pair<int, int>> frozenPairs;
    bool configured;
    FlavorParameters parameters;
    // The stiff clock parameter the runner was given (FlavorIntegrator::setStiffClockParameter).
    std::string clockParameter;
};

} // namespace FlavorPlugin

#endif

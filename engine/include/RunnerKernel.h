#ifndef OPENMM_FLAVORS_RUNNER_KERNEL_H_
#define OPENMM_FLAVORS_RUNNER_KERNEL_H_

#include "FlowStepRunner.h"
#include <memory>
#include <string>
#include <utility>

namespace FlavorPlugin {

/**
 * The part both step kernels share: a FlowStepRunner, to which the checkpoint, the Context's saved state and the step
 * history are handed under the integrator's name.
 */
template <class KernelInterface> class RunnerKernel : public KernelInterface {
public:
    RunnerKernel(std::string name, const OpenMM::Platform& platform, std::string integratorName)
        : KernelInterface(name, platform), integratorName(std::move(integratorName)) {}
    void createCheckpoint(OpenMM::ContextImpl& /*context*/, std::ostream& stream) const override {
        runner->createCheckpoint(stream, integratorName);
    }
    void loadCheckpoint(OpenMM::ContextImpl& context, std::istream& stream) override {
        runner->loadCheckpoint(context, stream, integratorName);
    }
    void saveContextState(OpenMM::ContextImpl& context, bool withParameters) override {
        runner->saveContextState(context, withParameters);
    }
    void forgetStepHistory() override { runner->forgetStepHistory(); }
    void getProposalCounts(long long& proposed, long long& accepted) const override {
        proposed = (long long)runner->getProposalCounts().proposed;
        accepted = (long long)runner->getProposalCounts().accepted;
    }

protected:
    std::unique_ptr<FlowStepRunner> runner;
    const std::string integratorName;
};

} // namespace FlavorPlugin

#endif

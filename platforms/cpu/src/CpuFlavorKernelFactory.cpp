#include "FlavorKernels.h"
#include "internal/FlavorStepKernel.h"
#include "internal/ParticleFlows.h"
#include "openmm/KernelFactory.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/cpu/CpuPlatform.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/internal/ThreadPool.h"
#include <algorithm>
#include <memory>

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

/**
 * Runs a pass on the CPU platform's thread pool, each thread on one contiguous block of particles.  The task
 * object is reused for every pass, so stepping allocates nothing.  Small systems run on the calling thread: waking
 * the pool costs more than the pass.
 */
class ThreadedParticleLoop : public ParticleLoop, private ThreadPool::Task {
public:
    explicit ThreadedParticleLoop(ThreadPool& threads) : threads(threads), pass(nullptr), numParticles(0) {}
    void run(const ParticlePass& currentPass, int count) override {
        if (count < MinParticlesPerThread * threads.getNumThreads()) {
            currentPass.apply(0, count);
            return;
        }
        pass = &currentPass;
        numParticles = count;
        threads.execute(*this);
        threads.waitForThreads();
    }

private:
    static constexpr int MinParticlesPerThread = 1024;
    void execute(ThreadPool& pool, int threadIndex) override {
        const int numThreads = pool.getNumThreads();
        const int begin = (int)((long long)numParticles * threadIndex / numThreads);
        const int end = (int)((long long)numParticles * (threadIndex + 1) / numThreads);
        pass->apply(begin, end);
    }
    ThreadPool& threads;
    const ParticlePass* pass;
    int numParticles;
};

class CpuFlavorKernelFactory : public KernelFactory {
public:
    KernelImpl* createKernelImpl(std::string name, const Platform& platform, ContextImpl& context) const override {
        CpuPlatform::PlatformData& data = CpuPlatform::getPlatformData(context);
        if (name == IntegrateFlavorStepKernel::Name())
            return new FlavorStepKernel(name, platform, std::make_unique<ThreadedParticleLoop>(data.threads));
        throw OpenMMException((std::string("Tried to create kernel with illegal kernel name '") + name + "'").c_str());
    }
};

void registerCpuKernels() {
    for (int i = 0; i < Platform::getNumPlatforms(); ++i) {
        Platform& platform = Platform::getPlatform(i);
        if (platform.getName() == "CPU") {
            CpuFlavorKernelFactory* factory = new CpuFlavorKernelFactory();
            platform.registerKernelFactory(IntegrateFlavorStepKernel::Name(), factory);
        }
    }
}

} // namespace

// Defined (empty) so that dlsym does not find libOpenMMCPU's registerPlatforms and create a second CPU platform.
extern "C" OPENMM_EXPORT_FLAVORS void registerPlatforms() {}

extern "C" OPENMM_EXPORT_FLAVORS void registerKernelFactories() {
    registerCpuKernels();
}

/** Registers the CPU kernels when a program links this library directly (tests, C++ examples). */
extern "C" OPENMM_EXPORT_FLAVORS void registerFlavorCpuKernelFactories() {
    registerCpuKernels();
}

#include "FlavorKernels.h"
#include "FlavorStepKernel.h"
#include "ImpulseStepKernel.h"
#include "ParticleFlows.h"
#include "openmm/KernelFactory.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/cpu/CpuPlatform.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/internal/ThreadPool.h"
#include <algorithm>
#include <atomic>
#include <memory>

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

/**
 * Runs a task on the CPU platform's thread pool: each thread on one contiguous block of indices, or, for tasks with
 * uneven items, one item at a time to whichever thread is free (items are independent, so the results do not depend
 * on the order).  The loop object is reused for every pass, so stepping allocates nothing.  Small tasks run on the
 * calling thread: waking the pool costs more than they do.
 */
class ThreadedLoop : public ParallelLoop, private ThreadPool::Task {
public:
    explicit ThreadedLoop(ThreadPool& threads) : threads(threads), task(nullptr), count(0) {}
    void run(const RangeTask& currentTask, int count) override {
        if (count < currentTask.minItemsPerThread() * threads.getNumThreads()) {
            currentTask.apply(0, count);
            return;
        }
        task = &currentTask;
        this->count = count;
        nextItem = 0;
        threads.execute(*this);
        threads.waitForThreads();
    }

private:
    void execute(ThreadPool& pool, int threadIndex) override {
        if (task->unevenItems()) {
            for (int item = nextItem++; item < count; item = nextItem++)
                task->apply(item, item + 1);
            return;
        }
        const int numThreads = pool.getNumThreads();
        const int begin = (int)((long long)count * threadIndex / numThreads);
        const int end = (int)((long long)count * (threadIndex + 1) / numThreads);
        task->apply(begin, end);
    }
    ThreadPool& threads;
    const RangeTask* task;
    int count;
    std::atomic<int> nextItem{0};
};

class CpuFlavorKernelFactory : public KernelFactory {
public:
    KernelImpl* createKernelImpl(std::string name, const Platform& platform, ContextImpl& context) const override {
        CpuPlatform::PlatformData& data = CpuPlatform::getPlatformData(context);
        if (name == IntegrateFlavorStepKernel::Name())
            return new FlavorStepKernel(name, platform, std::make_unique<ThreadedLoop>(data.threads));
        if (name == IntegrateStochasticImpulseStepKernel::Name())
            return new ImpulseStepKernel(name, platform, std::make_unique<ThreadedLoop>(data.threads));
        throw OpenMMException((std::string("Tried to create kernel with illegal kernel name '") + name + "'").c_str());
    }
};

void registerCpuKernels() {
    for (int i = 0; i < Platform::getNumPlatforms(); ++i) {
        Platform& platform = Platform::getPlatform(i);
        if (platform.getName() == "CPU") {
            CpuFlavorKernelFactory* factory = new CpuFlavorKernelFactory();
            platform.registerKernelFactory(IntegrateFlavorStepKernel::Name(), factory);
            platform.registerKernelFactory(IntegrateStochasticImpulseStepKernel::Name(), factory);
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

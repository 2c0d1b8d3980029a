// The step loops allocate nothing: counted with a replaced global operator new, against OpenMM's own
// VerletIntegrator, whose per-step allocations are those of one force evaluation on the platform (measured: 1 on
// Reference and 3 on CPU for this system, inside OpenMM's force kernels).  A Verlet FLAVOR step makes exactly three
// evaluations' worth and a Strang SIM step one: the integrators themselves add none.

#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/VerletIntegrator.h"
#include <atomic>
#include <cstdlib>
#include <memory>
#include <new>

namespace {
std::atomic<long> allocationCount{0};
}

void* operator new(std::size_t size) {
    allocationCount++;
    void* p = std::malloc(size == 0 ? 1 : size);
    if (p == nullptr)
        throw std::bad_alloc();
    return p;
}

void operator delete(void* p) noexcept {
    std::free(p);
}

void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;

class StepAllocations : public PlatformTest {
protected:
    /** Allocations per step, averaged over 50 steps after 5 warm-up steps. */
    double allocationsPerStep(Integrator& integrator) {
        std::unique_ptr<System> system(fpuSystem(3, 50.0, 400));
        Context context(*system, integrator, platform(), properties());
        context.setPositions(fpuPositions({1, 0.2, 0}, {0.02, 0, 0.01}, 400));
        integrator.step(5);
        long before = allocationCount;
        integrator.step(50);
        return (allocationCount - before) / 50.0;
    }
};
INSTANTIATE_ON_ALL_PLATFORMS(StepAllocations);

TEST_P(StepAllocations, StepsAllocateNoMoreThanTheirForceEvaluations) {
    VerletIntegrator verlet(1e-3);
    const double perEvaluation = allocationsPerStep(verlet);
    FlavorIntegrator flavor(0.01, 0.001, StiffMask);
    const double flavorSteps = allocationsPerStep(flavor);
    EXPECT_LE(flavorSteps, 3 * perEvaluation); // 3 evaluations per Verlet FLAVOR step
    FlavorIntegrator langevin(0.01, 0.001, StiffMask);
    langevin.setFriction(2.0);
    langevin.setTemperature(300);
    const double langevinSteps = allocationsPerStep(langevin);
    EXPECT_LE(langevinSteps, 3 * perEvaluation);
    StochasticImpulseIntegrator sim(300, 2.0, 0.01, StiffMask);
    const double simSteps = allocationsPerStep(sim);
    EXPECT_LE(simSteps, perEvaluation); // 1 evaluation per Strang step
    StochasticImpulseIntegrator filtered(300, 2.0, 0.01, StiffMask);
    filtered.setSplitting(StochasticImpulseIntegrator::Filtered);
    filtered.setStiffModeTemperature(1.0);
    filtered.setStiffModeFriction(20.0);
    const double filteredSteps = allocationsPerStep(filtered);
    EXPECT_LE(filteredSteps, perEvaluation); // 1 evaluation per Filtered step
    RecordProperty("filteredSimAllocationsPerStep", std::to_string(filteredSteps));
    RecordProperty("verletAllocationsPerStep", std::to_string(perEvaluation));
    RecordProperty("flavorAllocationsPerStep", std::to_string(flavorSteps));
    RecordProperty("langevinFlavorAllocationsPerStep", std::to_string(langevinSteps));
    RecordProperty("simAllocationsPerStep", std::to_string(simSteps));
}

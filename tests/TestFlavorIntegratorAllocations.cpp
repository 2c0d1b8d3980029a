// The step loops allocate nothing: counted with a replaced global operator new, against OpenMM's own
// VerletIntegrator, whose per-step allocations are those of one force evaluation on the platform (measured: 1 on
// Reference and 3 on CPU for this system, inside OpenMM's force kernels).  A Verlet FLAVOR step makes exactly three
// evaluations' worth and a Strang SIM step one: the integrators themselves add none.

#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/VerletIntegrator.h"
#include <atomic>
#include <cstdlib>
#include <functional>
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
    double allocationsPerStep(Integrator& integrator, bool bonded = false,
                              const std::function<void(System&)>& edit = nullptr) {
        // The FPU chains' stiff springs have rest length 0 (quadratic); bonded moves every rest length to 0.1, so
        // the artificial FLAVOR freezes them with the constraint solver.
        std::unique_ptr<System> system(fpuSystem(3, 50.0, 400));
        std::vector<Vec3> positions = fpuPositions({1, 0.2, 0}, {0.02, 0, 0.01}, 400);
        if (bonded) {
            HarmonicBondForce& bonds = dynamic_cast<HarmonicBondForce&>(system->getForce(0));
            for (int b = 0; b < bonds.getNumBonds(); ++b) {
                int p1, p2;
                double length, k;
                bonds.getBondParameters(b, p1, p2, length, k);
                bonds.setBondParameters(b, p1, p2, 0.1, k);
                positions[p2] = positions[p1] + Vec3(0.1, 0.01, 0.003);
            }
        }
        if (edit)
            edit(*system);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(positions);
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
    // Artificial Verlet FLAVOR: one soft and two stiff evaluations per step (the frozen drift moves the positions
    // between the last stiff kick of a step and the first of the next); with the exact fast flow only the soft one.
    // Their allocations are measured with VerletIntegrators that integrate only the soft or only the stiff group.
    VerletIntegrator softVerlet(1e-3), stiffVerlet(1e-3);
    softVerlet.setIntegrationForceGroups(~StiffMask);
    stiffVerlet.setIntegrationForceGroups(StiffMask);
    const double perSoftEvaluation = allocationsPerStep(softVerlet);
    const double perStiffEvaluation = allocationsPerStep(stiffVerlet);
    FlavorIntegrator artificial(0.01, 0.001, StiffMask);
    artificial.setAveraging(FlavorIntegrator::Artificial);
    const double artificialSteps = allocationsPerStep(artificial);
    EXPECT_LE(artificialSteps, perSoftEvaluation + 2 * perStiffEvaluation);
    FlavorIntegrator exact(0.01, 0.001, StiffMask);
    exact.setAveraging(FlavorIntegrator::ArtificialProjected);
    exact.setExactFastFlow(true);
    exact.setFriction(2.0);
    exact.setTemperature(300);
    EXPECT_LE(allocationsPerStep(exact), perSoftEvaluation);
    FlavorIntegrator bonded(0.01, 0.001, StiffMask);
    bonded.setAveraging(FlavorIntegrator::ArtificialProjected);
    const double bondedSteps = allocationsPerStep(bonded, true);
    EXPECT_LE(bondedSteps, perSoftEvaluation + 2 * perStiffEvaluation);
    RecordProperty("artificialAllocationsPerStep", std::to_string(artificialSteps));
    RecordProperty("bondedArtificialAllocationsPerStep", std::to_string(bondedSteps));
    RecordProperty("verletAllocationsPerStep", std::to_string(perEvaluation));
    RecordProperty("flavorAllocationsPerStep", std::to_string(flavorSteps));
    RecordProperty("langevinFlavorAllocationsPerStep", std::to_string(langevinSteps));
    RecordProperty("simAllocationsPerStep", std::to_string(simSteps));
}

TEST_P(StepAllocations, StiffClockStepsAllocateNoMoreThanTheirForceEvaluations) {
    // A stiff force that reads the clock: each stiff evaluation sets the parameter first.
    auto addClockedForce = [](System& system) {
        auto* forcing = new CustomExternalForce("0.01*sin(1000*stiffClockTime)*x");
        forcing->addGlobalParameter("stiffClockTime", 0.0);
        for (int i = 0; i < system.getNumParticles(); ++i)
            forcing->addParticle(i, {});
        forcing->setForceGroup(1);
        system.addForce(forcing);
    };
    VerletIntegrator verlet(1e-3);
    const double perEvaluation = allocationsPerStep(verlet, false, addClockedForce);
    FlavorIntegrator flavor(0.01, 0.001, StiffMask);
    flavor.setStiffClockParameter("stiffClockTime");
    const double flavorSteps = allocationsPerStep(flavor, false, addClockedForce);
    EXPECT_LE(flavorSteps, 3 * perEvaluation); // 3 evaluations per Verlet FLAVOR step, as without a clock
    RecordProperty("stiffClockFlavorAllocationsPerStep", std::to_string(flavorSteps));
}

// A splitting that neither integrator offers, run by the step engine from its schedule alone: the flow-first Strang
// step E(H/2) K_S(H) E(H/2), the other symmetric composition of the exact stiff flow and the soft kick.  Adding a
// splitting or a placement is this much: its sub-flows in a schedule (openmmapi/src/FlowSchedule.cpp builds the
// integrators' own), with every setting in the sub-flows.  The engine's executors do the rest.

#include "FlowStepRunner.h"
#include "PlatformTest.h"
#include "StiffProbe.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "internal/FlowSchedule.h"
#include "openmm/Context.h"
#include "openmm/Force.h"
#include "openmm/VerletIntegrator.h"
#include "openmm/internal/ForceImpl.h"
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class EngineSchedules : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(EngineSchedules);

namespace {

/** A force without forces that hands out the ContextImpl it is initialized with (the engine runs on one). */
class ContextImplProbe : public Force {
public:
    ContextImplProbe() : impl(std::make_shared<ContextImpl*>(nullptr)) {}
    ContextImpl& get() const { return **impl; }

protected:
    ForceImpl* createImpl() const override;

private:
    std::shared_ptr<ContextImpl*> impl;
    friend class ContextImplProbeImpl;
};

class ContextImplProbeImpl : public ForceImpl {
public:
    explicit ContextImplProbeImpl(const ContextImplProbe& owner) : owner(owner) {}
    void initialize(ContextImpl& context) override { *owner.impl = &context; }
    const Force& getOwner() const override { return owner; }
    void updateContextState(ContextImpl&, bool&) override {}
    double calcForcesAndEnergy(ContextImpl&, bool, bool, int) override { return 0.0; }
    std::map<std::string, double> getDefaultParameters() override { return {}; }
    std::vector<std::string> getKernelNames() override { return {}; }

private:
    const ContextImplProbe& owner;
};

ForceImpl* ContextImplProbe::createImpl() const {
    return new ContextImplProbeImpl(*this);
}

/** The flow-first Strang step over H: the stiff flow's settings are those of a frictionless SIM. */
Schedule flowFirstStrang(double H, int softGroups) {
    SubFlow halfFlow{SubFlow::StiffFlow, H / 2, 0};
    halfFlow.length = StepLength{0.5, 0};
    SubFlow kick{SubFlow::Kick, H, softGroups};
    kick.length = StepLength{1, 0};
    return {halfFlow, kick, halfFlow};
}

const double Duration = 0.2;

/** The FPU chains after Duration ps of the flow-first Strang step H, run by a FlowStepRunner. */
vector<Vec3> runFlowFirstStrang(Platform& platform, double H) {
    std::unique_ptr<System> system(fpuSystem(3, 50.0, 2));
    ContextImplProbe* probe = new ContextImplProbe();
    system->addForce(probe);
    VerletIntegrator unused(H);
    Context context(*system, unused, platform);
    context.setPositions(fpuPositions({1, 0.2, -0.4}, {0.02, -0.01, 0.01}, 2));
    ContextImpl& impl = probe->get();
    StiffModesMeasurement measurement(*system, "test", "");
    measurement.measure(impl, StiffMask, [](const StiffModes&) {});
    FlowStepRunner runner(*system, std::make_unique<SerialLoop>());
    runner.setStiffModes(measurement.getModes());
    runner.setSchedule(flowFirstStrang(H, ~StiffMask));
    EXPECT_EQ("E(H/2) K_S(H) E(H/2)   [E: zero modes 0 K, 0/ps, stiff modes 0 K, 0/ps]",
              describeSchedule(flowFirstStrang(H, ~StiffMask), StiffMask, AllForceGroups, "H", ""));
    bool forcesValid = false;
    const int steps = (int)std::lround(Duration / H);
    for (int i = 0; i < steps; ++i)
        runner.step(impl, 1e-10, H, forcesValid);
    return positionsOf(context);
}

} // namespace

TEST_P(EngineSchedules, ATestOnlyFlowFirstStrangScheduleIsASecondOrderIntegrator) {
    // The reference: the integrator's own Strang SIM at a step 40 times below the smallest tested one (its error,
    // second order too, is 1600 times smaller).
    std::unique_ptr<System> system(fpuSystem(3, 50.0, 2));
    StochasticImpulseIntegrator reference(0.0, 0.0, 2.5e-5, StiffMask);
    Context context(*system, reference, platform());
    context.setPositions(fpuPositions({1, 0.2, -0.4}, {0.02, -0.01, 0.01}, 2));
    reference.step((int)std::lround(Duration / 2.5e-5));
    const vector<Vec3> exact = positionsOf(context);
    vector<double> errors;
    for (double H : {0.004, 0.002, 0.001}) {
        errors.push_back(relativeDifference(runFlowFirstStrang(platform(), H), exact));
        std::ostringstream error;
        error << errors.back();
        RecordProperty("error at H = " + std::to_string(H), error.str());
    }
    // Halving H divides a second-order error by 4.
    for (int k = 0; k < 2; ++k) {
        EXPECT_GT(errors[k] / errors[k + 1], 3.5) << "H = " << 0.004 / (1 << k);
        EXPECT_LT(errors[k] / errors[k + 1], 4.5) << "H = " << 0.004 / (1 << k);
    }
    EXPECT_LT(errors[2], 1e-3);
}

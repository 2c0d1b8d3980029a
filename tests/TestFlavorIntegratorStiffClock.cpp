// The stiff clock (FlavorIntegrator::setStiffClockParameter): the clock value every force evaluation sees, the
// reduction tau = delta to physical time, the force cache across clock values, checkpoints, setTime and the rejected
// settings.

#include "ExpectRejected.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "internal/FlowSchedule.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/Force.h"
#include "openmm/System.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/internal/ForceImpl.h"
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorStiffClock : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorStiffClock);

namespace {

const char* Clock = "clock";

/**
 * A force that adds nothing but records, at each evaluation of its group, the global parameter "clock" (which it
 * defines) and the Context's time: a witness of the clock each evaluation sees.
 */
class ClockRecordingForce : public Force {
public:
    struct Record {
        double clock, time;
    };
    ClockRecordingForce() : records(std::make_shared<vector<Record>>()) {}
    const vector<Record>& getRecords() const { return *records; }

protected:
    ForceImpl* createImpl() const override;

private:
    std::shared_ptr<vector<Record>> records;
    friend class ClockRecordingForceImpl;
};

class ClockRecordingForceImpl : public ForceImpl {
public:
    explicit ClockRecordingForceImpl(const ClockRecordingForce& owner) : owner(owner) {}
    void initialize(ContextImpl& /*context*/) override {}
    const Force& getOwner() const override { return owner; }
    void updateContextState(ContextImpl& /*context*/, bool& /*forcesInvalid*/) override {}
    double calcForcesAndEnergy(ContextImpl& context, bool includeForces, bool /*includeEnergy*/, int groups) override {
        if (includeForces && (groups & (1 << owner.getForceGroup())) != 0)
            owner.records->push_back({context.getParameter(Clock), context.getTime()});
        return 0.0;
    }
    std::map<std::string, double> getDefaultParameters() override { return {{Clock, 0.0}}; }
    std::vector<std::string> getKernelNames() override { return {}; }

private:
    const ClockRecordingForce& owner;
};

ForceImpl* ClockRecordingForce::createImpl() const {
    return new ClockRecordingForceImpl(*this);
}

/** One particle: a soft spring (group 0) and a stiff force that oscillates with the clock (group 1). */
struct ClockSystem {
    System system;
    ClockRecordingForce* soft;
    ClockRecordingForce* stiff;
    ClockSystem() {
        system.addParticle(2.0);
        auto* spring = new CustomExternalForce("0.5*x^2");
        spring->addParticle(0, {});
        system.addForce(spring);
        auto* forcing = new CustomExternalForce("300*sin(2000*clock)*cos(x)");
        forcing->addGlobalParameter(Clock, 0.0);
        forcing->addParticle(0, {});
        forcing->setForceGroup(1);
        system.addForce(forcing);
        soft = new ClockRecordingForce();
        system.addForce(soft);
        stiff = new ClockRecordingForce();
        stiff->setForceGroup(1);
        system.addForce(stiff);
    }
};

const int StiffMask = 1 << 1;

void start(Context& context) {
    context.setPositions({Vec3(0.3, 0, 0)});
    context.setVelocities({Vec3(0.1, 0, 0)});
}

/** A ClockSystem stepped by a FlavorIntegrator on the stiff clock "clock", started from the same state. */
struct ClockRun {
    ClockSystem s;
    FlavorIntegrator integrator;
    std::unique_ptr<Context> context;
    ClockRun(double delta, double tau, FlavorIntegrator::Scheme scheme, Platform& platform,
             const std::map<std::string, std::string>& properties)
        : integrator(delta, tau, StiffMask) {
        integrator.setScheme(scheme);
        integrator.setStiffClockParameter(Clock);
        context = std::make_unique<Context>(s.system, integrator, platform, properties);
        start(*context);
    }
};

/** Expects count records whose clocks are 0, tau, tau + tau, ... (accumulated as the stiff clock advances). */
void expectAccumulatedClocks(const vector<ClockRecordingForce::Record>& records, int count, double tau) {
    ASSERT_EQ(count, (int)records.size());
    double expected = 0.0;
    for (int k = 0; k < count; ++k) {
        EXPECT_EQ(expected, records[k].clock) << "stiff evaluation " << k;
        expected += tau;
    }
}

} // namespace

TEST_P(FlavorStiffClock, VerletStepReadsTheClockAtBothEndsOfItsMicrostep) {
    const double delta = 0.004, tau = 0.001;
    const int steps = 5;
    ClockRun run(delta, tau, FlavorIntegrator::Verlet, platform(), properties());
    const ClockSystem& s = run.s;
    run.integrator.step(steps);
    // Stiff: the opening kick at clock 0, then one evaluation per step at its closing kick, which the next step's
    // opening kick reuses: n tau, accumulated as the clock advances.
    expectAccumulatedClocks(s.stiff->getRecords(), steps + 1, tau);
    // Soft: the stiff evaluations plus two soft kicks per step; the soft-only ones leave the parameter as the last
    // stiff evaluation set it (the step's opening clock), at the step's physical time.
    const vector<ClockRecordingForce::Record>& soft = s.soft->getRecords();
    ASSERT_EQ(3 * steps + 1, (int)soft.size());
    double clock = 0.0, time = 0.0;
    for (int k = 0; k < steps; ++k) {
        for (int e = 1; e <= 2; ++e) {
            EXPECT_EQ(clock, soft[3 * k + e].clock) << "step " << k << ", soft kick " << e;
            EXPECT_NEAR(time, soft[3 * k + e].time, 1e-15);
        }
        clock += tau;
        time += delta;
        EXPECT_EQ(clock, soft[3 * k + 3].clock) << "step " << k << ", closing kick";
    }
}

TEST_P(FlavorStiffClock, SymplecticEulerStepReadsTheClockWhereItsMicrostepStarts) {
    const double delta = 0.004, tau = 0.001;
    const int steps = 5;
    ClockRun run(delta, tau, FlavorIntegrator::SymplecticEuler, platform(), properties());
    const ClockSystem& s = run.s;
    run.integrator.step(steps);
    const vector<ClockRecordingForce::Record>& stiff = s.stiff->getRecords();
    expectAccumulatedClocks(stiff, steps, tau);
    // K_A(tau) then K_S(delta - tau): the soft kick sees the clock its step's stiff kick set.
    const vector<ClockRecordingForce::Record>& soft = s.soft->getRecords();
    ASSERT_EQ(2 * steps, (int)soft.size());
    for (int k = 0; k < steps; ++k)
        EXPECT_EQ(stiff[k].clock, soft[2 * k + 1].clock) << "step " << k;
}

TEST_P(FlavorStiffClock, WithEqualStepsTheClockIsThePhysicalTime) {
    const double h = 0.002;
    ClockRun run(h, h, FlavorIntegrator::Verlet, platform(), properties());
    for (int k = 0; k < 20; ++k) {
        run.integrator.step(1);
        EXPECT_EQ(run.context->getState(0).getTime(), run.s.stiff->getRecords().back().clock) << "step " << k;
    }
    // And a time set from outside restarts the clock there (times tau/delta = 1).
    run.context->setTime(3.25);
    run.integrator.step(1);
    const vector<ClockRecordingForce::Record>& stiff = run.s.stiff->getRecords();
    EXPECT_EQ(3.25, stiff[stiff.size() - 2].clock);
    EXPECT_EQ(3.25 + h, stiff.back().clock);
}

TEST_P(FlavorStiffClock, TimeSetFromOutsideRestartsTheClockScaledByTauOverDelta) {
    ClockRun run(0.004, 0.001, FlavorIntegrator::SymplecticEuler, platform(), properties());
    run.context->setTime(2.0);
    run.integrator.step(1);
    EXPECT_DOUBLE_EQ(0.5, run.s.stiff->getRecords().back().clock);
}

TEST_P(FlavorStiffClock, WithoutAClockTheParameterIsLeftAlone) {
    ClockSystem s;
    FlavorIntegrator integrator(0.004, 0.001, StiffMask);
    Context context(s.system, integrator, platform(), properties());
    start(context);
    context.setParameter(Clock, 0.75);
    integrator.step(3);
    for (const ClockRecordingForce::Record& record : s.stiff->getRecords())
        EXPECT_EQ(0.75, record.clock);
}

TEST_P(FlavorStiffClock, CheckpointContinuesTheClockBitForBit) {
    const double delta = 0.004, tau = 0.0003;
    ClockRun run(delta, tau, FlavorIntegrator::Verlet, platform(), properties());
    run.integrator.step(37);
    std::stringstream checkpoint;
    run.context->createCheckpoint(checkpoint);
    run.integrator.step(50);
    const double first = run.context->getState(State::Positions).getPositions()[0][0];
    const double firstClock = run.s.stiff->getRecords().back().clock;
    run.context->loadCheckpoint(checkpoint);
    run.integrator.step(50);
    EXPECT_EQ(first, run.context->getState(State::Positions).getPositions()[0][0]);
    EXPECT_EQ(firstClock, run.s.stiff->getRecords().back().clock);
    // A new Context from the checkpoint continues the same way (its first step does not restart the clock).
    ClockRun other(delta, tau, FlavorIntegrator::Verlet, platform(), properties());
    checkpoint.clear();
    checkpoint.seekg(0);
    other.context->loadCheckpoint(checkpoint);
    other.integrator.step(50);
    EXPECT_EQ(first, other.context->getState(State::Positions).getPositions()[0][0]);
    EXPECT_EQ(firstClock, other.s.stiff->getRecords().back().clock);
}

TEST_P(FlavorStiffClock, UnknownParameterIsRejectedByName) {
    ClockSystem s;
    FlavorIntegrator integrator(0.004, 0.001, StiffMask);
    integrator.setStiffClockParameter("tick");
    expectRejected([&] { Context context(s.system, integrator, platform(), properties()); },
                   {"stiffClockParameter", "\"tick\"", "clock"});

    FlavorIntegrator bound(0.004, 0.001, StiffMask);
    bound.setStiffClockParameter(Clock);
    Context context(s.system, bound, platform(), properties());
    expectRejected([&] { bound.setStiffClockParameter("tock"); }, {"stiffClockParameter", "\"tock\""});
    EXPECT_EQ(Clock, bound.getStiffClockParameter());
    bound.setStiffClockParameter("");
    EXPECT_EQ("", bound.getStiffClockParameter());
}

TEST(FlavorStiffClockRules, ArtificialAveragingsRejectAClock) {
    FlavorParameters p{FlavorIntegrator::Verlet,
                       FlavorIntegrator::Artificial,
                       false,
                       0.004,
                       0.001,
                       StiffMask,
                       AllForceGroups,
                       0.0,
                       false,
                       FlavorIntegrator::Edges};
    p.stiffClock = true;
    expectRejected([&] { validateFlavorStep(p); }, {"setStiffClockParameter", "Artificial (1)", "Nonintrusive"});
    p.averaging = FlavorIntegrator::Nonintrusive;
    validateFlavorStep(p);
    // Its kicks of stiff groups carry the clock; two of them, at 0 and tau, each their own setting.
    Schedule schedule = flavorSchedule(p);
    vector<double> clocks;
    for (const SubFlow& flow : schedule)
        if (flow.clocked)
            clocks.push_back(flow.clock);
    EXPECT_EQ((vector<double>{0.0, 0.001}), clocks);
}

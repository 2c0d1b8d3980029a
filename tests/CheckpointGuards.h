#ifndef OPENMM_FLAVORS_TESTS_CHECKPOINT_GUARDS_H_
#define OPENMM_FLAVORS_TESTS_CHECKPOINT_GUARDS_H_

// Checkpoints that are not the integrator's: the load must throw, name what the checkpoint holds and leave the
// Context (positions, velocities, box, time, step count, parameters) and the integrator's random streams as they
// were.

#include "ExpectRejected.h"
#include "openmm/Context.h"
#include "openmm/Integrator.h"
#include "openmm/State.h"
#include <gtest/gtest.h>
#include <sstream>
#include <string>
#include <vector>

namespace FlavorTests {

/** A checkpoint that should be rejected and what the message must say about it. */
struct ForeignCheckpoint {
    std::string label;
    std::string bytes;
    std::vector<std::string> fragments;
};

/** Every position, velocity, box vector, time, step count and parameter of a Context, compared exactly. */
struct ContextSnapshot {
    std::vector<OpenMM::Vec3> positions, velocities;
    OpenMM::Vec3 box[3];
    double time;
    long long stepCount;
    std::map<std::string, double> parameters;

    explicit ContextSnapshot(OpenMM::Context& context) {
        OpenMM::State state =
            context.getState(OpenMM::State::Positions | OpenMM::State::Velocities | OpenMM::State::Parameters);
        positions = state.getPositions();
        velocities = state.getVelocities();
        state.getPeriodicBoxVectors(box[0], box[1], box[2]);
        time = state.getTime();
        stepCount = context.getStepCount();
        parameters = state.getParameters();
    }
    void expectEqual(const ContextSnapshot& other, const std::string& label) const {
        EXPECT_EQ(time, other.time) << label;
        EXPECT_EQ(stepCount, other.stepCount) << label;
        EXPECT_EQ(parameters, other.parameters) << label;
        for (int i = 0; i < 3; ++i)
            for (int d = 0; d < 3; ++d)
                EXPECT_EQ(box[i][d], other.box[i][d]) << label;
        ASSERT_EQ(positions.size(), other.positions.size());
        for (size_t i = 0; i < positions.size(); ++i)
            for (int d = 0; d < 3; ++d) {
                EXPECT_EQ(positions[i][d], other.positions[i][d]) << label << " particle " << i;
                EXPECT_EQ(velocities[i][d], other.velocities[i][d]) << label << " particle " << i;
            }
    }
};

/**
 * Loads each foreign checkpoint into context (whose integrator is driven by step) and expects a rejection that
 * leaves the Context as it was; then the run continues exactly as the twin Context, which saw no load, does.
 */
template <class StepFunction>
void expectForeignCheckpointsRejected(OpenMM::Context& context, StepFunction step, OpenMM::Context& twin,
                                      StepFunction twinStep, const std::vector<ForeignCheckpoint>& foreign) {
    for (const ForeignCheckpoint& checkpoint : foreign) {
        const ContextSnapshot before(context);
        std::istringstream stream(checkpoint.bytes);
        expectRejected([&] { context.loadCheckpoint(stream); }, checkpoint.fragments);
        ContextSnapshot(context).expectEqual(before, checkpoint.label);
        // The random streams are the ones of the twin, which loaded nothing.
        step(context, 5);
        twinStep(twin, 5);
        ContextSnapshot(context).expectEqual(ContextSnapshot(twin), checkpoint.label + ", 5 steps later");
    }
}

} // namespace FlavorTests

#endif

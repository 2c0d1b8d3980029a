#ifndef OPENMM_FLAVORS_PARTICLE_FLOWS_H_
#define OPENMM_FLAVORS_PARTICLE_FLOWS_H_

#include "CounterRandom.h"
#include "FlowSchedule.h"
#include "openmm/Vec3.h"
#include <cstdint>

namespace FlavorPlugin {

/** The largest number of distinct force-group sets one step kicks with. */
constexpr int MaxForceSlots = 4;

/** A sub-flow with its per-step constants precomputed. */
struct PreparedFlow {
    SubFlow::Kind kind;
    double h;
    /** Kick: the force slot it reads. */
    int slot;
    /** Thermostat: exp(-friction h) and sqrt(1 - exp(-2 friction h)). */
    double decay, noise;
    /** Thermostat: the random stream it draws from, relative to the step's first stream. */
    int streamOffset;
};

/**
 * Work that splits into independent index ranges [begin, end).
 */
class RangeTask {
public:
    virtual ~RangeTask() = default;
    virtual void apply(int begin, int end) const = 0;
};

/**
 * Runs a RangeTask over [0, count).  Each platform supplies one: plain loops, or its thread pool.
 */
class ParallelLoop {
public:
    virtual ~ParallelLoop() = default;
    virtual void run(const RangeTask& task, int count) = 0;
};

/**
 * Everything one pass over the particles needs.  apply() is the only place where kicks, drifts and
 * Ornstein-Uhlenbeck flows touch particle data, for every platform.
 */
struct ParticlePass : public RangeTask {
    const PreparedFlow* flows = nullptr;
    int numFlows = 0;
    const OpenMM::Vec3* slotForces[MaxForceSlots] = {};
    OpenMM::Vec3* positions = nullptr;
    OpenMM::Vec3* velocities = nullptr;
    const double* inverseMasses = nullptr;
    /** sqrt(kT/m) for each particle. */
    const double* thermalSpeeds = nullptr;
    const CounterRandom* random = nullptr;
    std::uint64_t firstStream = 0;

    void apply(int begin, int end) const override {
        for (int i = begin; i < end; ++i) {
            const double invMass = inverseMasses[i];
            if (invMass == 0.0)
                continue;
            OpenMM::Vec3 x = positions[i], v = velocities[i];
            for (int k = 0; k < numFlows; ++k) {
                const PreparedFlow& flow = flows[k];
                switch (flow.kind) {
                case SubFlow::Kick:
                    v += slotForces[flow.slot][i] * (flow.h * invMass);
                    break;
                case SubFlow::Drift:
                    x += v * flow.h;
                    break;
                case SubFlow::Thermostat: {
                    std::array<double, 3> xi = random->normals(firstStream + flow.streamOffset, (std::uint32_t)i);
                    v = v * flow.decay + OpenMM::Vec3(xi[0], xi[1], xi[2]) * (flow.noise * thermalSpeeds[i]);
                    break;
                }
                }
            }
            positions[i] = x;
            velocities[i] = v;
        }
    }
};

} // namespace FlavorPlugin

#endif

#ifndef OPENMM_FLAVORS_PARTICLE_FLOWS_H_
#define OPENMM_FLAVORS_PARTICLE_FLOWS_H_

#include "CounterRandom.h"
#include "FlowSchedule.h"
#include "openmm/Vec3.h"
#include <algorithm>
#include <array>
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

    /** 1 for particles that move, 0 for massless ones (which OpenMM's integrators never move). */
    const double* movable = nullptr;
    /** 1 for particles the thermostats act on, 0 for the others. */
    const double* thermostated = nullptr;

    void apply(int begin, int end) const override {
        // Flow by flow over cache-sized blocks: tight loops per flow, and the block stays in cache between flows.
        constexpr int BlockSize = 256;
        for (int first = begin; first < end; first += BlockSize) {
            const int last = std::min(end, first + BlockSize);
            for (int k = 0; k < numFlows; ++k) {
                const PreparedFlow& flow = flows[k];
                switch (flow.kind) {
                case SubFlow::Kick:
                    kick(flow, first, last);
                    break;
                case SubFlow::Drift:
                    drift(flow, first, last);
                    break;
                case SubFlow::Thermostat:
                    thermostat(flow, first, last);
                    break;
                case SubFlow::StiffFlow:
                    break; // never in a particle pass (compileStepPlan)
                }
            }
        }
    }

private:
    // Vec3 stores three contiguous doubles; plain arrays let the compiler keep these loops tight.
    void kick(const PreparedFlow& flow, int first, int last) const {
        const double* f = reinterpret_cast<const double*>(slotForces[flow.slot]);
        double* v = reinterpret_cast<double*>(velocities);
        const double h = flow.h;
        for (int i = first; i < last; ++i) {
            const double scale = h * inverseMasses[i];
            v[3 * i] += scale * f[3 * i];
            v[3 * i + 1] += scale * f[3 * i + 1];
            v[3 * i + 2] += scale * f[3 * i + 2];
        }
    }
    void drift(const PreparedFlow& flow, int first, int last) const {
        double* x = reinterpret_cast<double*>(positions);
        const double* v = reinterpret_cast<const double*>(velocities);
        const double h = flow.h;
        for (int i = first; i < last; ++i) {
            const double scale = h * movable[i];
            x[3 * i] += scale * v[3 * i];
            x[3 * i + 1] += scale * v[3 * i + 1];
            x[3 * i + 2] += scale * v[3 * i + 2];
        }
    }
    void thermostat(const PreparedFlow& flow, int first, int last) const {
        const std::uint64_t stream = firstStream + flow.streamOffset;
        for (int i = first; i < last; ++i) {
            if (movable[i] == 0.0 || thermostated[i] == 0.0)
                continue;
            std::array<double, 3> xi = random->normals(stream, (std::uint32_t)i);
            velocities[i] =
                velocities[i] * flow.decay + OpenMM::Vec3(xi[0], xi[1], xi[2]) * (flow.noise * thermalSpeeds[i]);
        }
    }
};

} // namespace FlavorPlugin

#endif

#ifndef OPENMM_FLAVORS_PARTICLE_FLOWS_H_
#define OPENMM_FLAVORS_PARTICLE_FLOWS_H_

#include "internal/CounterRandom.h"
#include "internal/FlowSchedule.h"
#include "openmm/Vec3.h"
#include <algorithm>
#include <array>
#include <cstdint>

namespace FlavorPlugin {

/** The largest number of distinct force-group sets one step kicks with. */
constexpr int MaxForceSlots = 4;

/** A sub-flow of a particle pass with its per-step constants precomputed. */
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
    /** The fewest items per thread worth waking a thread pool for (many for a particle's few operations). */
    virtual int minItemsPerThread() const { return 1024; }
    /**
     * Whether items differ widely in their work (constraint clusters of one to thousands of rows): a thread pool then
     * hands them out one at a time to whichever thread is free, instead of in equal contiguous blocks.
     */
    virtual bool unevenItems() const { return false; }
};

/**
 * Runs a RangeTask over [0, count).  Each platform supplies one: plain loops, or its thread pool.
 */
class ParallelLoop {
public:
    virtual ~ParallelLoop() = default;
    virtual void run(const RangeTask& task, int count) = 0;
};

/** A ParallelLoop on the calling thread alone. */
class SerialLoop : public ParallelLoop {
public:
    void run(const RangeTask& task, int count) override { task.apply(0, count); }
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
    /** 1/m for each coordinate (three per particle), 0 for massless particles. */
    const double* coordinateInverseMasses = nullptr;
    /** sqrt(kT/m) for each particle. */
    const double* thermalSpeeds = nullptr;
    const CounterRandom* random = nullptr;
    std::uint64_t firstStream = 0;

    /**
     * 1 for each coordinate (three per particle) of particles that move, 0 for massless ones (which OpenMM's
     * integrators never move).
     */
    const double* coordinateMovable = nullptr;
    /** 1 for particles the thermostats act on, 0 for the others. */
    const double* thermostated = nullptr;

    void apply(int begin, int end) const override {
        if (numFlows == 1 && flows[0].kind == SubFlow::Kick) {
            // The common single kick needs no blocks.
            kick(flows[0], begin, end);
            return;
        }
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
                case SubFlow::FilteredStiffFlow:
                case SubFlow::FilteredKick:
                case SubFlow::HarmonicFlow:
                case SubFlow::FrozenDrift:
                case SubFlow::FrozenKick:
                case SubFlow::ProposalStart:
                case SubFlow::ProposalTest:
                case SubFlow::HardWall:
                case SubFlow::HardWallSpeed:
                    break; // never in a particle pass (analyzeStep)
                }
            }
        }
    }

private:
    // Vec3 stores three contiguous doubles: flat loops over coordinates of distinct arrays vectorize.
    void kick(const PreparedFlow& flow, int first, int last) const {
        const double* __restrict f = reinterpret_cast<const double*>(slotForces[flow.slot]);
        double* __restrict v = reinterpret_cast<double*>(velocities);
        const double* __restrict inverseMass = coordinateInverseMasses;
        const double h = flow.h;
        for (int k = 3 * first; k < 3 * last; ++k)
            v[k] += (h * inverseMass[k]) * f[k];
    }
    void drift(const PreparedFlow& flow, int first, int last) const {
        double* __restrict x = reinterpret_cast<double*>(positions);
        const double* __restrict v = reinterpret_cast<const double*>(velocities);
        const double* __restrict moves = coordinateMovable;
        const double h = flow.h;
        for (int k = 3 * first; k < 3 * last; ++k)
            x[k] += (h * moves[k]) * v[k];
    }
    void thermostat(const PreparedFlow& flow, int first, int last) const {
        const std::uint64_t stream = firstStream + flow.streamOffset;
        for (int i = first; i < last; ++i) {
            if (coordinateMovable[3 * i] == 0.0 || thermostated[i] == 0.0)
                continue;
            std::array<double, 3> xi = random->normals(stream, (std::uint32_t)i);
            velocities[i] =
                velocities[i] * flow.decay + OpenMM::Vec3(xi[0], xi[1], xi[2]) * (flow.noise * thermalSpeeds[i]);
        }
    }
};

} // namespace FlavorPlugin

#endif

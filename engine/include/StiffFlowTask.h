#ifndef OPENMM_FLAVORS_STIFF_FLOW_TASK_H_
#define OPENMM_FLAVORS_STIFF_FLOW_TASK_H_

#include "ParticleFlows.h"
#include "StiffModes.h"
#include "internal/CounterRandom.h"
#include "openmm/Vec3.h"
#include <cstdint>
#include <vector>

namespace FlavorPlugin {

/**
 * Applies a StiffModes::Propagator to positions and velocities, one component per index of the range.  The step
 * engine sets the fields before each run: the particle data, the random stream of the noise (two draws per particle,
 * 2i and 2i + 1) and, optionally, a kick v += kickStep F / m that precedes the flow and is applied as velocities are
 * read, saving a pass over the particles.
 */
class StiffFlowTask : public RangeTask {
public:
    /** Selects each component's compiled flow and sizes the scratch of the others; nothing is allocated later. */
    explicit StiffFlowTask(const StiffModes& modes);
    void apply(int begin, int end) const override;

    const StiffModes::Propagator* propagator = nullptr;
    OpenMM::Vec3* positions = nullptr;
    OpenMM::Vec3* velocities = nullptr;
    const CounterRandom* random = nullptr;
    std::uint64_t stream = 0;
    /** When not null, the forces of the kick fused into this flow, with inverseMasses per particle. */
    const OpenMM::Vec3* kickForces = nullptr;
    const double* inverseMasses = nullptr;
    double kickStep = 0.0;

    /**
     * The flow of one small component, compiled for its size: its particles, its part of the propagator data and
     * the task being applied.
     */
    typedef void (*ComponentFlow)(const int* particles, const double* propagator, const StiffFlowTask& task);

private:
    /** The general flow of a component too large for a compiled one. */
    void applyLarge(int component, const double* propagator) const;
    const StiffModes& modes;
    // Per component: its compiled flows without and with noise (nullptr for large ones), and its slice of scratch.
    std::vector<ComponentFlow> flows, noisyFlows;
    std::vector<std::size_t> scratchOffset;
    // Each large component's incoming and outgoing state and its noise, one slice per component so that components can
    // run in parallel.
    mutable std::vector<double> scratch;
};

/**
 * Adds a StiffModes::ForceResponse to a force to positions and velocities, one component per index of the range:
 * x += M^-1/2 U diag(rx) U^T M^-1/2 F and likewise v with rv.
 */
class ForceResponseTask : public RangeTask {
public:
    /** Sizes the scratch; nothing is allocated later. */
    explicit ForceResponseTask(const StiffModes& modes);
    void apply(int begin, int end) const override;

    const StiffModes::ForceResponse* response = nullptr;
    const OpenMM::Vec3* forces = nullptr;
    /**
     * When not null, the velocity processing of a Filtered kick, applied in stiff components to the change of the
     * forces over the step: the opening kick (closing false) reads the changes and records forces in openingForces,
     * the closing one computes the changes (forces - openingForces) and records them.
     */
    const StiffModes::ForceResponse* processing = nullptr;
    bool closing = false;
    OpenMM::Vec3* openingForces = nullptr;
    OpenMM::Vec3* forceChanges = nullptr;
    OpenMM::Vec3* positions = nullptr;
    OpenMM::Vec3* velocities = nullptr;

private:
    /** apply() for component c; FixedRows and FixedColumns are its sizes, or 0 to read them from the component. */
    template <int FixedRows, int FixedColumns> void applyComponent(int c, const double* r, const double* q) const;
    const StiffModes& modes;
    std::vector<std::size_t> scratchOffset;
    // Per component: the force in particle and in mode coordinates, the two responses, then the force change in
    // particle and in mode coordinates, D x C each.
    mutable std::vector<double> scratch;
};

} // namespace FlavorPlugin

#endif

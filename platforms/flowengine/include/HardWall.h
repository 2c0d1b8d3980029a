#ifndef OPENMM_FLAVORS_HARD_WALL_H_
#define OPENMM_FLAVORS_HARD_WALL_H_

#include "ParticleTable.h"
#include "StiffModes.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/Vec3.h"
#include <vector>

namespace FlavorPlugin {

/**
 * The hard wall of the stiff pairs (StochasticImpulseIntegrator::setMaxDrudeDistance), as DrudeLangevinIntegrator
 * applies it: every stiff component of two particles (a Drude particle, the lighter, and its parent) farther apart
 * than the wall is put back inside, the overshoot reflected for the time it spent beyond, and its relative radial
 * velocity set to the thermal speed of the stiff bath, inward; a parent that is constrained or massless stays where it
 * is.  One implementation for every platform's step: the host engine's HardWall sub-flow, and the common compute
 * platforms on host copies of their particle data.
 */
class OPENMM_EXPORT_FLAVORS HardWall {
public:
    /** Finds the stiff pairs of modes (none without modes). */
    void setStiffModes(const StiffModes* modes, const ParticleTable& table);
    /**
     * Applies the wall (nm) after a step of length dt with the stiff bath's kT; returns whether anything moved.
     * Throws, before anything moves, if a pair is farther apart than twice the wall.
     */
    bool apply(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
               const std::vector<double>& masses, double wall, double dt, double kT) const;

private:
    struct Pair {
        int drude, parent;
        /** Whether the parent stays where it is (constrained or massless). */
        bool parentFixed;
    };
    std::vector<Pair> pairs;
};

} // namespace FlavorPlugin

#endif

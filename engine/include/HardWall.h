#ifndef OPENMM_FLAVORS_HARD_WALL_H_
#define OPENMM_FLAVORS_HARD_WALL_H_

#include "ParticleTable.h"
#include "StiffModes.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/Vec3.h"
#include <string>
#include <vector>

namespace FlavorPlugin {

/**
 * The hard wall of the stiff pairs (StochasticImpulseIntegrator::setMaxDrudeDistance), as DrudeLangevinIntegrator
 * applies it, in two parts around the step's closing kick: every stiff component of two particles (a Drude particle,
 * the lighter, and its parent) farther apart than the wall is put back inside, the overshoot reflected for the step at
 * the thermal speed of the stiff bath (movePositions), and after the kick its relative radial velocity set to that
 * speed, inward (setSpeeds); a parent that is constrained or massless stays where it is.  One implementation for every
 * platform's step: the host engine's HardWall and HardWallSpeed sub-flows, and the common compute platforms on host
 * copies of their particle data.
 */
class OPENMM_EXPORT_FLAVORS HardWall {
public:
    /** Finds the stiff pairs of modes (none without modes). */
    void setStiffModes(const StiffModes* modes, const ParticleTable& table);
    /**
     * Puts the pairs farther apart than the wall (nm) back inside, the overshoot reflected for a step of length dt at
     * the thermal speed of kT, and remembers them and their axes for setSpeeds(); returns whether anything moved.
     * Throws, before anything moves, if a pair is farther apart than twice the wall.
     */
    bool movePositions(std::vector<OpenMM::Vec3>& positions, const std::vector<double>& masses, double wall, double dt,
                       double kT);
    /**
     * Sets the relative radial velocity of the pairs the last movePositions() put back, along their axes then, to the
     * thermal speed of kT pointing inward, with each pair's centre-of-mass velocity and tangential motion kept;
     * returns whether there were any.
     */
    bool setSpeeds(std::vector<OpenMM::Vec3>& velocities, const std::vector<double>& masses, double kT);
    /** Whether the last movePositions() put any pair back. */
    bool movedAny() const { return !moved.empty(); }

    struct Pair {
        int drude, parent;
        /** Whether the parent stays where it is (constrained or massless). */
        bool parentFixed;
    };
    /** The stiff pairs of the modes last set. */
    const std::vector<Pair>& getPairs() const { return pairs; }
    /** Why a step fails whose pair drude-parent is distance nm apart (or more: distance negative) after its flow. */
    static std::string tooFarMessage(int drude, int parent, double distance, double wall);

private:
    std::vector<Pair> pairs;
    /** The pairs the last movePositions() put back (indices into pairs) and their axes, parent to Drude. */
    std::vector<int> moved;
    std::vector<OpenMM::Vec3> axes;
};

} // namespace FlavorPlugin

#endif

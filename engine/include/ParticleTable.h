#ifndef OPENMM_FLAVORS_PARTICLE_TABLE_H_
#define OPENMM_FLAVORS_PARTICLE_TABLE_H_

#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <vector>

namespace FlavorPlugin {

/** The per-particle constants of a System that every part of the step engine reads. */
struct OPENMM_EXPORT_FLAVORS ParticleTable {
    explicit ParticleTable(const OpenMM::System& system);
    int numParticles;
    bool hasConstraints, hasVirtualSites;
    std::vector<double> masses;
    /** 1/m, 0 for massless particles (which OpenMM's integrators never move). */
    std::vector<double> inverseMasses;
    /** Per coordinate (three per particle), for the particle passes: 1/m, and 1 for particles that move, else 0. */
    std::vector<double> coordinateInverseMasses, coordinateMovable;
    /** 1 for particles that a System constraint names. */
    std::vector<char> constrained;
    /** The kinetic energy of velocities (kJ/mol), summed in the System's order. */
    double kineticEnergy(const std::vector<OpenMM::Vec3>& velocities) const;
};

} // namespace FlavorPlugin

#endif

#include "ParticleTable.h"

using namespace FlavorPlugin;

ParticleTable::ParticleTable(const OpenMM::System& system)
    : numParticles(system.getNumParticles()), hasConstraints(system.getNumConstraints() > 0), hasVirtualSites(false) {
    masses.resize(numParticles);
    inverseMasses.resize(numParticles);
    coordinateInverseMasses.resize(3 * (size_t)numParticles);
    coordinateMovable.resize(3 * (size_t)numParticles);
    for (int i = 0; i < numParticles; ++i) {
        masses[i] = system.getParticleMass(i);
        inverseMasses[i] = (masses[i] == 0.0 ? 0.0 : 1.0 / masses[i]);
        for (int d = 0; d < 3; ++d) {
            coordinateInverseMasses[3 * i + d] = inverseMasses[i];
            coordinateMovable[3 * i + d] = (masses[i] == 0.0 ? 0.0 : 1.0);
        }
        hasVirtualSites = hasVirtualSites || system.isVirtualSite(i);
    }
}

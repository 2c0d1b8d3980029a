#include "ParticleTable.h"

using namespace FlavorPlugin;

double ParticleTable::kineticEnergy(const std::vector<OpenMM::Vec3>& velocities) const {
    double twice = 0.0;
    for (int i = 0; i < numParticles; ++i)
        twice += masses[i] * velocities[i].dot(velocities[i]);
    return 0.5 * twice;
}

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
    constrained.assign(numParticles, 0);
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        constrained[p1] = constrained[p2] = 1;
    }
}

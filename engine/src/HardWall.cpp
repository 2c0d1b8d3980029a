#include "HardWall.h"
#include "internal/ParameterChecks.h"
#include "openmm/OpenMMException.h"
#include <cmath>
#include <string>

using namespace FlavorPlugin;
using namespace OpenMM;

void HardWall::setStiffModes(const StiffModes* modes, const ParticleTable& table) {
    pairs.clear();
    if (!modes)
        return;
    for (int c = 0; c < modes->getNumComponents(); ++c) {
        if (!modes->getComponent(c).stiff || modes->getComponent(c).numParticles != 2)
            continue;
        const int* members = modes->getComponentParticles(c);
        const bool firstLighter = table.masses[members[0]] < table.masses[members[1]];
        Pair pair{firstLighter ? members[0] : members[1], firstLighter ? members[1] : members[0], false};
        pair.parentFixed = table.constrained[pair.parent] != 0 || table.masses[pair.parent] == 0.0;
        pairs.push_back(pair);
    }
    moved.clear();
    axes.clear();
    moved.reserve(pairs.size()); // no allocation in the step
    axes.reserve(pairs.size());
}

std::string HardWall::tooFarMessage(int drude, int parent, double distance, double wall) {
    const std::string apart = distance >= 0 ? " is " + std::to_string(distance) + " nm apart" : " is farther apart";
    return "StochasticImpulseIntegrator: the stiff pair of particles " + std::to_string(drude) + " and " +
           std::to_string(parent) + apart + " after the step, more than twice the hard wall (setMaxDrudeDistance, " +
           formatNumber(wall) + " nm): the step is too large for this System";
}

bool HardWall::movePositions(std::vector<Vec3>& positions, const std::vector<double>& masses, double wall, double dt,
                             double kT) {
    // Checked before anything moves: a pair past twice the wall leaves the positions as the step's flow left them.
    for (const Pair& pair : pairs) {
        const Vec3 delta = positions[pair.drude] - positions[pair.parent];
        const double r = std::sqrt(delta.dot(delta));
        if (!(r <= 2 * wall))
            throw OpenMMException(tooFarMessage(pair.drude, pair.parent, r, wall));
    }
    moved.clear();
    axes.clear();
    for (size_t i = 0; i < pairs.size(); ++i) {
        const Pair& pair = pairs[i];
        const Vec3 delta = positions[pair.drude] - positions[pair.parent];
        const double r = std::sqrt(delta.dot(delta));
        if (r <= wall)
            continue;
        const Vec3 axis = delta / r;
        // Back inside by the overshoot and by what the thermal speed covers in the step, as a pair that spent the
        // whole step beyond the wall would be reflected.
        const double inward = (r - wall) + dt * std::sqrt(kT / masses[pair.drude]);
        if (pair.parentFixed) {
            positions[pair.drude] -= axis * inward;
        } else {
            const double m1 = masses[pair.drude], m2 = masses[pair.parent], inverseTotal = 1.0 / (m1 + m2);
            positions[pair.drude] -= axis * (inward * m2 * inverseTotal);
            positions[pair.parent] += axis * (inward * m1 * inverseTotal);
        }
        moved.push_back((int)i);
        axes.push_back(axis);
    }
    return !moved.empty();
}

bool HardWall::setSpeeds(std::vector<Vec3>& velocities, const std::vector<double>& masses, double kT) {
    for (size_t k = 0; k < moved.size(); ++k) {
        const Pair& pair = pairs[moved[k]];
        const Vec3& axis = axes[k];
        const double m1 = masses[pair.drude], m2 = masses[pair.parent];
        const double speed = std::sqrt(kT / m1);
        Vec3& v1 = velocities[pair.drude];
        Vec3& v2 = velocities[pair.parent];
        const double radial1 = v1.dot(axis), radial2 = v2.dot(axis);
        if (pair.parentFixed) {
            v1 += axis * (radial2 - speed - radial1);
            continue;
        }
        const double inverseTotal = 1.0 / (m1 + m2);
        const double centre = (m1 * radial1 + m2 * radial2) * inverseTotal;
        v1 += axis * (centre - speed * m2 * inverseTotal - radial1);
        v2 += axis * (centre + speed * m1 * inverseTotal - radial2);
    }
    return !moved.empty();
}

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
}

bool HardWall::apply(std::vector<Vec3>& positions, std::vector<Vec3>& velocities, const std::vector<double>& masses,
                     double wall, double dt, double kT) const {
    // Checked before anything moves: a pair past twice the wall leaves the Context at the step's end as it was.
    for (const Pair& pair : pairs) {
        const Vec3 delta = positions[pair.drude] - positions[pair.parent];
        const double r = std::sqrt(delta.dot(delta));
        if (!(r <= 2 * wall))
            throw OpenMMException("StochasticImpulseIntegrator: the stiff pair of particles " +
                                  std::to_string(pair.drude) + " and " + std::to_string(pair.parent) + " is " +
                                  std::to_string(r) +
                                  " nm apart after the step, more than twice the hard wall "
                                  "(setMaxDrudeDistance, " +
                                  formatNumber(wall) + " nm): the step is too large for this System");
    }
    bool moved = false;
    for (const Pair& pair : pairs) {
        const Vec3 delta = positions[pair.drude] - positions[pair.parent];
        const double r = std::sqrt(delta.dot(delta));
        if (r <= wall)
            continue;
        moved = true;
        const Vec3 direction = delta / r;
        const double excess = r - wall;
        const double m1 = masses[pair.drude], m2 = masses[pair.parent];
        Vec3& v1 = velocities[pair.drude];
        Vec3& v2 = velocities[pair.parent];
        double radial1 = v1.dot(direction);
        const Vec3 across1 = v1 - direction * radial1;
        double radial2 = v2.dot(direction);
        if (pair.parentFixed) {
            // Only the Drude particle moves: back from the wall for the time it spent beyond it, inward relative to
            // its parent at the thermal speed.
            const double relative = radial1 - radial2;
            const double overTime = relative != 0.0 ? std::min(dt, excess / std::abs(relative)) : dt;
            const double speed = std::sqrt(kT / m1);
            positions[pair.drude] += direction * (-excess - overTime * speed);
            v1 = across1 + direction * (radial2 - speed);
            continue;
        }
        const Vec3 across2 = v2 - direction * radial2;
        const double inverseTotal = 1.0 / (m1 + m2);
        const double centre = (m1 * radial1 + m2 * radial2) * inverseTotal;
        radial1 -= centre;
        radial2 -= centre;
        const double overTime = radial1 != radial2 ? std::min(dt, excess / std::abs(radial1 - radial2)) : dt;
        const double speed = std::sqrt(kT / m1);
        const double inward1 = -speed * m2 * inverseTotal, inward2 = speed * m1 * inverseTotal;
        positions[pair.drude] += direction * (-excess * m2 * inverseTotal + overTime * inward1);
        positions[pair.parent] += direction * (excess * m1 * inverseTotal + overTime * inward2);
        v1 = across1 + direction * (inward1 + centre);
        v2 = across2 + direction * (inward2 + centre);
    }
    return moved;
}

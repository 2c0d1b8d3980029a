#include "FlavorIntegrator.h"
#include "internal/ParameterChecks.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/System.h"
#include <cmath>
#include <map>
#include <set>
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

struct AngleTerm {
    HarmonicAngleForce* force;
    int index, particle1, particle3;
    double theta, k;
};

} // namespace

int FlavorIntegrator::separatePlanarAngles(System& system, int group, double minAngleSum) {
    const std::string owner = "FlavorIntegrator::separatePlanarAngles";
    if (group < 0 || group > 31)
        throwInvalidParameter(owner, "group", std::to_string(group), "force groups are 0 to 31");
    if (!(minAngleSum > 0.0 && minAngleSum <= 2.0 * M_PI))
        throwInvalidParameter(owner, "minAngleSum", formatNumber(minAngleSum),
                              "it must be above 0 and at most 2 pi (radians)");
    std::map<int, std::vector<AngleTerm>> byCentre;
    for (int f = 0; f < system.getNumForces(); ++f) {
        HarmonicAngleForce* force = dynamic_cast<HarmonicAngleForce*>(&system.getForce(f));
        if (force == nullptr || force->getForceGroup() == group) // angles already in the group stay where they are
            continue;
        for (int a = 0; a < force->getNumAngles(); ++a) {
            AngleTerm term{force, a, 0, 0, 0.0, 0.0};
            int centre;
            force->getAngleParameters(a, term.particle1, centre, term.particle3, term.theta, term.k);
            if (term.k != 0.0)
                byCentre[centre].push_back(term);
        }
    }
    HarmonicAngleForce* planar = nullptr;
    int moved = 0;
    for (auto& entry : byCentre) {
        const std::vector<AngleTerm>& terms = entry.second;
        std::set<int> neighbours;
        double angleSum = 0.0;
        for (const AngleTerm& t : terms) {
            neighbours.insert(t.particle1);
            neighbours.insert(t.particle3);
            angleSum += t.theta;
        }
        if (terms.size() != 3 || neighbours.size() != 3 || angleSum < minAngleSum)
            continue;
        if (planar == nullptr) {
            planar = new HarmonicAngleForce();
            planar->setForceGroup(group);
            planar->setUsesPeriodicBoundaryConditions(terms[0].force->usesPeriodicBoundaryConditions());
        }
        for (const AngleTerm& t : terms) {
            planar->addAngle(t.particle1, entry.first, t.particle3, t.theta, t.k);
            t.force->setAngleParameters(t.index, t.particle1, entry.first, t.particle3, t.theta, 0.0);
            ++moved;
        }
    }
    if (planar != nullptr)
        system.addForce(planar);
    return moved;
}

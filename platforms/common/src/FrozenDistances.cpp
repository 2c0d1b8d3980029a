#include "FrozenDistances.h"
#include "openmm/CustomBondForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferenceCCMAAlgorithm.h"
#include <algorithm>
#include <cmath>
#include <set>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::pair;
using std::string;
using std::vector;

namespace {

pair<int, int> ordered(int a, int b) {
    return a < b ? pair<int, int>(a, b) : pair<int, int>(b, a);
}

} // namespace

vector<pair<int, int>> FlavorPlugin::bondedFrozenPairs(const ContextImpl& context, int stiffGroups,
                                                       const vector<pair<int, int>>& extra,
                                                       vector<string>& unsupported) {
    const System& system = context.getSystem();
    vector<pair<int, int>> result;
    std::set<pair<int, int>> seen;
    auto add = [&](int a, int b) {
        if (seen.insert(ordered(a, b)).second)
            result.push_back(ordered(a, b));
    };
    unsupported.clear();
    for (int f = 0; f < system.getNumForces(); ++f) {
        const Force& force = system.getForce(f);
        if ((stiffGroups & (1 << force.getForceGroup())) == 0)
            continue;
        if (const HarmonicBondForce* bonds = dynamic_cast<const HarmonicBondForce*>(&force)) {
            for (int b = 0; b < bonds->getNumBonds(); ++b) {
                int p1, p2;
                double length, k;
                bonds->getBondParameters(b, p1, p2, length, k);
                add(p1, p2);
            }
        } else if (const CustomBondForce* custom = dynamic_cast<const CustomBondForce*>(&force)) {
            for (int b = 0; b < custom->getNumBonds(); ++b) {
                int p1, p2;
                vector<double> parameters;
                custom->getBondParameters(b, p1, p2, parameters);
                add(p1, p2);
            }
        } else if (const HarmonicAngleForce* angles = dynamic_cast<const HarmonicAngleForce*>(&force)) {
            for (int a = 0; a < angles->getNumAngles(); ++a) {
                int p1, p2, p3;
                double angle, k;
                angles->getAngleParameters(a, p1, p2, p3, angle, k);
                add(p1, p3);
            }
        } else {
            unsupported.push_back("force " + std::to_string(f) + " (" + force.getName() + ", force group " +
                                  std::to_string(force.getForceGroup()) + ")");
        }
    }
    for (const pair<int, int>& p : extra)
        add(p.first, p.second);
    return result;
}

/** OpenMM's CCMA solver whose constraint lengths can be set before each use. */
class FrozenDistances::Solver : public ReferenceCCMAAlgorithm {
public:
    Solver(int numAtoms, const vector<pair<int, int>>& pairs, const vector<double>& distances, vector<double>& masses,
           vector<AngleInfo>& angles)
        : ReferenceCCMAAlgorithm(numAtoms, (int)pairs.size(), pairs, distances, masses, angles, 0.02) {}
    void setDistance(int index, double distance) { _distance[index] = distance; }
};

FrozenDistances::FrozenDistances(const System& system, const vector<pair<int, int>>& frozenPairs) {
    const int n = system.getNumParticles();
    std::set<pair<int, int>> constrained;
    vector<double> distances;
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        pairs.emplace_back(p1, p2);
        distances.push_back(distance);
        constrained.insert(ordered(p1, p2));
    }
    numSystem = (int)pairs.size();
    for (const pair<int, int>& p : frozenPairs) {
        if (system.getParticleMass(p.first) == 0.0 || system.getParticleMass(p.second) == 0.0)
            throw OpenMMException("FlavorIntegrator: the frozen distance between particles " + std::to_string(p.first) +
                                  " and " + std::to_string(p.second) +
                                  " involves a massless particle; massless particles do not move and cannot be "
                                  "frozen.  Move the force acting on it to a soft group");
        if (constrained.count(ordered(p.first, p.second)) == 0) {
            pairs.push_back(p);
            distances.push_back(0.1); // set from the positions before each use
        }
    }
    numFrozen = (int)pairs.size() - numSystem;
    vector<double> masses(n);
    for (int i = 0; i < n; ++i)
        masses[i] = system.getParticleMass(i);
    // The angles shape CCMA's coupling matrix (its preconditioner), as in OpenMM's own constraint set-up.
    vector<ReferenceCCMAAlgorithm::AngleInfo> angles;
    for (int f = 0; f < system.getNumForces(); ++f)
        if (const HarmonicAngleForce* force = dynamic_cast<const HarmonicAngleForce*>(&system.getForce(f)))
            for (int a = 0; a < force->getNumAngles(); ++a) {
                int p1, p2, p3;
                double angle, k;
                force->getAngleParameters(a, p1, p2, p3, angle, k);
                angles.emplace_back(p1, p2, p3, angle);
            }
    solver = std::make_unique<Solver>(n, pairs, distances, masses, angles);
    targetRates.assign(pairs.size(), 0.0);
    previousPositions.resize(n);
    scratch.resize(n);
}

FrozenDistances::~FrozenDistances() = default;

void FrozenDistances::drift(vector<Vec3>& positions, vector<Vec3>& velocities, vector<double>& inverseMasses, double h,
                            double tolerance) {
    const int n = (int)positions.size();
    // Store the rates of the frozen distances and hold them at their current lengths.
    for (int c = numSystem; c < (int)pairs.size(); ++c) {
        const Vec3 r = positions[pairs[c].first] - positions[pairs[c].second];
        const double length = std::sqrt(r.dot(r));
        solver->setDistance(c, length);
        targetRates[c] = r.dot(velocities[pairs[c].first] - velocities[pairs[c].second]) / length;
    }
    solver->applyToVelocities(positions, velocities, inverseMasses, tolerance);
    previousPositions = positions;
    for (int i = 0; i < n; ++i)
        if (inverseMasses[i] != 0.0)
            positions[i] += velocities[i] * h;
    solver->apply(previousPositions, positions, inverseMasses, tolerance);
    const double inverseTime = 1.0 / h;
    for (int i = 0; i < n; ++i)
        if (inverseMasses[i] != 0.0)
            velocities[i] = (positions[i] - previousPositions[i]) * inverseTime;
    solver->applyToVelocities(positions, velocities, inverseMasses, tolerance);
    restoreRates(positions, velocities, inverseMasses, tolerance);
}

void FrozenDistances::kick(vector<Vec3>& positions, vector<Vec3>& velocities, const vector<Vec3>& forces,
                           vector<double>& inverseMasses, double h, double tolerance) {
    const int n = (int)positions.size();
    for (int i = 0; i < n; ++i)
        scratch[i] = forces[i] * (h * inverseMasses[i]);
    solver->applyToVelocities(positions, scratch, inverseMasses, tolerance);
    for (int i = 0; i < n; ++i)
        velocities[i] += scratch[i];
}

void FrozenDistances::restoreRates(const vector<Vec3>& positions, vector<Vec3>& velocities,
                                   const vector<double>& inverseMasses, double tolerance) {
    // RATTLE's velocity iteration with nonzero targets: v_i += w_i d u, v_j -= w_j d u along each constraint's unit
    // vector u, which solves (J M^-1 J^T) lambda = target - J v by Gauss-Seidel sweeps.
    const int maxSweeps = 500;
    for (int sweep = 0; sweep < maxSweeps; ++sweep) {
        double largest = 0.0;
        for (size_t c = 0; c < pairs.size(); ++c) {
            const int i = pairs[c].first, j = pairs[c].second;
            const double wi = inverseMasses[i], wj = inverseMasses[j];
            if (wi + wj == 0.0)
                continue;
            Vec3 u = positions[i] - positions[j];
            u *= 1.0 / std::sqrt(u.dot(u));
            const Vec3 relative = velocities[i] - velocities[j];
            const double error = targetRates[c] - u.dot(relative);
            const double scale = std::sqrt(relative.dot(relative)) + std::abs(targetRates[c]);
            if (scale > 0.0)
                largest = std::max(largest, std::abs(error) / scale);
            const double d = error / (wi + wj);
            velocities[i] += u * (wi * d);
            velocities[j] -= u * (wj * d);
        }
        if (largest <= tolerance)
            return;
    }
}

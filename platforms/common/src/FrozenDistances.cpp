#include "FrozenDistances.h"
#include "openmm/CustomBondForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
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

FrozenDistances::FrozenDistances(const System& system, const vector<pair<int, int>>& frozenPairs) {
    std::set<pair<int, int>> constrained;
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        pairs.emplace_back(p1, p2);
        lengths.push_back(distance);
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
            lengths.push_back(0.0); // set from the positions before each drift
        }
    }
    numFrozen = (int)pairs.size() - numSystem;
    targetRates.assign(pairs.size(), 0.0);
    zeroRates.assign(pairs.size(), 0.0);
    previousPositions.resize(system.getNumParticles());
    scratch.resize(system.getNumParticles());
}

void FrozenDistances::drift(vector<Vec3>& positions, vector<Vec3>& velocities, const vector<double>& inverseMasses,
                            double h, double tolerance) {
    const int n = (int)positions.size();
    // Store the rates of the frozen distances and hold them at their current lengths.
    for (int c = numSystem; c < (int)pairs.size(); ++c) {
        const Vec3 r = positions[pairs[c].first] - positions[pairs[c].second];
        lengths[c] = std::sqrt(r.dot(r));
        targetRates[c] = r.dot(velocities[pairs[c].first] - velocities[pairs[c].second]) / lengths[c];
    }
    constrainVelocities(positions, velocities, inverseMasses, zeroRates, tolerance);
    previousPositions = positions;
    for (int i = 0; i < n; ++i)
        if (inverseMasses[i] != 0.0)
            positions[i] += velocities[i] * h;
    constrainPositions(positions, inverseMasses, tolerance);
    const double inverseTime = 1.0 / h;
    for (int i = 0; i < n; ++i)
        if (inverseMasses[i] != 0.0)
            velocities[i] = (positions[i] - previousPositions[i]) * inverseTime;
    // Back onto the tangent space at the new positions (RATTLE), then the stored rates along the new directions:
    // one solve with the targets does both.
    constrainVelocities(positions, velocities, inverseMasses, targetRates, tolerance);
}

void FrozenDistances::kick(const vector<Vec3>& positions, vector<Vec3>& velocities, const vector<Vec3>& forces,
                           const vector<double>& inverseMasses, double h, double tolerance) {
    const int n = (int)positions.size();
    for (int i = 0; i < n; ++i)
        scratch[i] = forces[i] * (h * inverseMasses[i]);
    constrainVelocities(positions, scratch, inverseMasses, zeroRates, tolerance);
    for (int i = 0; i < n; ++i)
        velocities[i] += scratch[i];
}

void FrozenDistances::constrainPositions(vector<Vec3>& positions, const vector<double>& inverseMasses,
                                         double tolerance) {
    // SHAKE: Gauss-Seidel sweeps, each constraint corrected along its direction before the drift.
    for (int sweep = 0; sweep < MaxSweeps; ++sweep) {
        bool converged = true;
        for (size_t c = 0; c < pairs.size(); ++c) {
            const int i = pairs[c].first, j = pairs[c].second;
            const double wi = inverseMasses[i], wj = inverseMasses[j];
            if (wi + wj == 0.0)
                continue;
            const Vec3 r = positions[i] - positions[j];
            const Vec3 reference = previousPositions[i] - previousPositions[j];
            const double target = lengths[c] * lengths[c];
            const double difference = target - r.dot(r);
            if (std::abs(difference) <= 2 * tolerance * target)
                continue;
            converged = false;
            const double g = difference / (2 * (wi + wj) * r.dot(reference));
            positions[i] += reference * (wi * g);
            positions[j] -= reference * (wj * g);
        }
        if (converged)
            return;
    }
    throw OpenMMException("FlavorIntegrator: the frozen distances could not be held to the constraint tolerance " +
                          std::to_string(tolerance) + " in " + std::to_string(MaxSweeps) +
                          " iterations; the simulation is unstable (reduce the mesostep)");
}

void FrozenDistances::constrainVelocities(const vector<Vec3>& positions, vector<Vec3>& velocities,
                                          const vector<double>& inverseMasses, const vector<double>& targets,
                                          double tolerance) {
    // RATTLE's velocity step with targets: v_i += w_i d u, v_j -= w_j d u along each constraint's unit vector u, which
    // solves (J M^-1 J^T) lambda = targets - J v by Gauss-Seidel sweeps.
    for (int sweep = 0; sweep < MaxSweeps; ++sweep) {
        bool converged = true;
        for (size_t c = 0; c < pairs.size(); ++c) {
            const int i = pairs[c].first, j = pairs[c].second;
            const double wi = inverseMasses[i], wj = inverseMasses[j];
            if (wi + wj == 0.0)
                continue;
            Vec3 u = positions[i] - positions[j];
            u *= 1.0 / std::sqrt(u.dot(u));
            const Vec3 relative = velocities[i] - velocities[j];
            const double error = targets[c] - u.dot(relative);
            const double scale = std::sqrt(relative.dot(relative)) + std::abs(targets[c]);
            if (std::abs(error) <= tolerance * scale)
                continue;
            converged = false;
            const double d = error / (wi + wj);
            velocities[i] += u * (wi * d);
            velocities[j] -= u * (wj * d);
        }
        if (converged)
            return;
    }
}

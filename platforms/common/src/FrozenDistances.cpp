#include "FrozenDistances.h"
#include "internal/UnionFind.h"
#include "openmm/CustomBondForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include <algorithm>
#include <cmath>
#include <set>
#include <utility>

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

FrozenDistances::FrozenDistances(const System& system, const vector<pair<int, int>>& frozenPairs)
    : positions(nullptr), velocities(nullptr), forces(nullptr), inverseMasses(nullptr), h(0.0), tolerance(0.0),
      kicking(false) {
    const int n = system.getNumParticles();
    vector<pair<int, int>> all;
    vector<double> allLengths;
    vector<bool> allFrozen;
    std::set<pair<int, int>> constrained;
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        all.emplace_back(p1, p2);
        allLengths.push_back(distance);
        allFrozen.push_back(false);
        constrained.insert(ordered(p1, p2));
    }
    for (const pair<int, int>& p : frozenPairs) {
        if (system.getParticleMass(p.first) == 0.0 || system.getParticleMass(p.second) == 0.0)
            throw OpenMMException("FlavorIntegrator: the frozen distance between particles " + std::to_string(p.first) +
                                  " and " + std::to_string(p.second) +
                                  " involves a massless particle; massless particles do not move and cannot be "
                                  "frozen.  Move the force acting on it to a soft group");
        if (constrained.count(ordered(p.first, p.second)) == 0) {
            all.push_back(p);
            allLengths.push_back(0.0); // set from the positions before each drift
            allFrozen.push_back(true);
        }
    }
    numFrozen = 0;
    for (bool f : allFrozen)
        numFrozen += f ? 1 : 0;
    // Clusters: the connected components of the constraint graph over particles with mass.  Each is solved on its
    // own, so clusters run in parallel; a particle without constraints is a cluster of its own.
    vector<int> parent(n);
    for (int i = 0; i < n; ++i)
        parent[i] = i;
    for (const pair<int, int>& p : all)
        parent[findRoot(parent, p.first)] = findRoot(parent, p.second);
    vector<int> clusterOf(n, -1);
    int numClusters = 0;
    for (int i = 0; i < n; ++i) {
        if (system.getParticleMass(i) == 0.0)
            continue;
        const int root = findRoot(parent, i);
        if (clusterOf[root] < 0)
            clusterOf[root] = numClusters++;
        clusterOf[i] = clusterOf[root];
    }
    vector<vector<int>> clusterParticles(numClusters), clusterConstraints(numClusters);
    // Massless particles never move (as in OpenMM's integrators): they belong to no cluster's particle list.
    for (int i = 0; i < n; ++i)
        if (clusterOf[i] >= 0 && system.getParticleMass(i) != 0.0)
            clusterParticles[clusterOf[i]].push_back(i);
    for (size_t c = 0; c < all.size(); ++c) {
        const int cluster = clusterOf[findRoot(parent, all[c].first)];
        if (cluster >= 0)
            clusterConstraints[cluster].push_back((int)c);
    }
    particleStart.push_back(0);
    constraintStart.push_back(0);
    for (int k = 0; k < numClusters; ++k) {
        particles.insert(particles.end(), clusterParticles[k].begin(), clusterParticles[k].end());
        for (int c : clusterConstraints[k]) {
            pairs.push_back(all[c]);
            lengths.push_back(allLengths[c]);
            frozen.push_back(allFrozen[c] ? 1 : 0);
        }
        particleStart.push_back((int)particles.size());
        constraintStart.push_back((int)pairs.size());
    }
    targetRates.assign(pairs.size(), 0.0);
    previousPositions.resize(n);
    scratch.resize(n);
    failed.assign(numClusters, 0);
}

void FrozenDistances::drift(vector<Vec3>& q, vector<Vec3>& v, const vector<double>& w, double step, double tol,
                            ParallelLoop& loop) {
    positions = q.data();
    velocities = v.data();
    inverseMasses = w.data();
    h = step;
    tolerance = tol;
    kicking = false;
    loop.run(*this, getNumClusters());
    checkConvergence();
}

void FrozenDistances::kick(vector<Vec3>& q, vector<Vec3>& v, const vector<Vec3>& f, const vector<double>& w,
                           double step, double tol, ParallelLoop& loop) {
    positions = q.data();
    velocities = v.data();
    forces = f.data();
    inverseMasses = w.data();
    h = step;
    tolerance = tol;
    kicking = true;
    loop.run(*this, getNumClusters());
}

void FrozenDistances::checkConvergence() {
    for (size_t k = 0; k < failed.size(); ++k)
        if (failed[k]) {
            std::fill(failed.begin(), failed.end(), 0);
            throw OpenMMException("FlavorIntegrator: the frozen distances could not be held to the constraint "
                                  "tolerance " +
                                  std::to_string(tolerance) + " in " + std::to_string(MaxSweeps) +
                                  " iterations; the simulation is unstable (reduce the mesostep)");
        }
}

void FrozenDistances::apply(int begin, int end) const {
    for (int k = begin; k < end; ++k) {
        if (kicking)
            kickCluster(k);
        else
            driftCluster(k);
    }
}

void FrozenDistances::driftCluster(int k) const {
    const int firstConstraint = constraintStart[k], lastConstraint = constraintStart[k + 1];
    // Store the rates of the frozen distances and hold them at their current lengths.
    for (int c = firstConstraint; c < lastConstraint; ++c) {
        if (!frozen[c])
            continue;
        const Vec3 r = positions[pairs[c].first] - positions[pairs[c].second];
        lengths[c] = std::sqrt(r.dot(r));
        targetRates[c] = r.dot(velocities[pairs[c].first] - velocities[pairs[c].second]) / lengths[c];
    }
    constrainVelocities(k, velocities, false);
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
        const int i = particles[n];
        previousPositions[i] = positions[i];
        positions[i] += velocities[i] * h;
    }
    if (lastConstraint == firstConstraint)
        return;
    if (!constrainPositions(k))
        failed[k] = 1;
    const double inverseTime = 1.0 / h;
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
        const int i = particles[n];
        velocities[i] = (positions[i] - previousPositions[i]) * inverseTime;
    }
    // Back onto the tangent space at the new positions (RATTLE), then the stored rates along the new directions:
    // one solve with the targets does both.
    constrainVelocities(k, velocities, true);
}

void FrozenDistances::kickCluster(int k) const {
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
        const int i = particles[n];
        scratch[i] = forces[i] * (h * inverseMasses[i]);
    }
    constrainVelocities(k, scratch.data(), false);
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
        const int i = particles[n];
        velocities[i] += scratch[i];
    }
}

bool FrozenDistances::constrainPositions(int k) const {
    // SHAKE: Gauss-Seidel sweeps, each constraint corrected along its direction before the drift.
    for (int sweep = 0; sweep < MaxSweeps; ++sweep) {
        bool converged = true;
        for (int c = constraintStart[k]; c < constraintStart[k + 1]; ++c) {
            const int i = pairs[c].first, j = pairs[c].second;
            const double wi = inverseMasses[i], wj = inverseMasses[j];
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
            return true;
    }
    return false;
}

void FrozenDistances::constrainVelocities(int k, Vec3* v, bool withTargets) const {
    // RATTLE's velocity step with targets (the stored rates of the frozen distances, 0 for the System's constraints,
    // or 0 for all): v_i += w_i d u, v_j -= w_j d u along each constraint's unit vector u, which solves
    // (J M^-1 J^T) lambda = targets - J v by Gauss-Seidel sweeps.
    for (int sweep = 0; sweep < MaxSweeps; ++sweep) {
        bool converged = true;
        for (int c = constraintStart[k]; c < constraintStart[k + 1]; ++c) {
            const int i = pairs[c].first, j = pairs[c].second;
            const double wi = inverseMasses[i], wj = inverseMasses[j];
            Vec3 u = positions[i] - positions[j];
            u *= 1.0 / std::sqrt(u.dot(u));
            const Vec3 relative = v[i] - v[j];
            const double target = withTargets ? targetRates[c] : 0.0;
            const double error = target - u.dot(relative);
            const double scale = std::sqrt(relative.dot(relative)) + std::abs(target);
            if (std::abs(error) <= tolerance * scale)
                continue;
            converged = false;
            const double d = error / (wi + wj);
            v[i] += u * (wi * d);
            v[j] -= u * (wj * d);
        }
        if (converged)
            return;
    }
}

#include "FrozenDistances.h"
#include "internal/StiffGroupChecks.h"
#include "internal/UnionFind.h"
#include "openmm/CustomBondForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferenceConstraints.h"
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
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

vector<pair<int, int>> FlavorPlugin::nonredundantAngleDistances(const vector<std::array<int, 3>>& angles) {
    // The neighbours of each centre in order of first appearance.
    std::map<int, vector<int>> neighbours;
    for (const std::array<int, 3>& angle : angles)
        for (int end : {angle[0], angle[2]}) {
            vector<int>& list = neighbours[angle[1]];
            if (std::find(list.begin(), list.end(), end) == list.end())
                list.push_back(end);
        }
    vector<pair<int, int>> result;
    for (const std::array<int, 3>& angle : angles) {
        const vector<int>& list = neighbours[angle[1]];
        const int k = (int)list.size();
        const int a = (int)(std::find(list.begin(), list.end(), angle[0]) - list.begin());
        const int b = (int)(std::find(list.begin(), list.end(), angle[2]) - list.begin());
        const int low = std::min(a, b), high = std::max(a, b);
        if (low > 1 || (k == 3 && low == 1 && high == 2))
            continue;
        result.push_back(ordered(angle[0], angle[2]));
    }
    return result;
}

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
    vector<std::array<int, 3>> angles;
    for (int f = 0; f < system.getNumForces(); ++f) {
        const Force& force = system.getForce(f);
        if ((stiffGroups & (1 << force.getForceGroup())) == 0)
            continue;
        if (const HarmonicBondForce* bonds = dynamic_cast<const HarmonicBondForce*>(&force)) {
            for (int b = 0; b < bonds->getNumBonds(); ++b) {
                int p1, p2;
                double length, k;
                bonds->getBondParameters(b, p1, p2, length, k);
                if (k != 0.0) // no stiff force, nothing to hold
                    add(p1, p2);
            }
        } else if (const CustomBondForce* custom = dynamic_cast<const CustomBondForce*>(&force)) {
            for (int b = 0; b < custom->getNumBonds(); ++b) {
                int p1, p2;
                vector<double> parameters;
                custom->getBondParameters(b, p1, p2, parameters);
                add(p1, p2);
            }
        } else if (const HarmonicAngleForce* angleForce = dynamic_cast<const HarmonicAngleForce*>(&force)) {
            for (int a = 0; a < angleForce->getNumAngles(); ++a) {
                std::array<int, 3> angle;
                double theta, k;
                angleForce->getAngleParameters(a, angle[0], angle[1], angle[2], theta, k);
                if (k != 0.0)
                    angles.push_back(angle);
            }
        } else {
            unsupported.push_back(describeForce(system, f));
        }
    }
    for (const pair<int, int>& p : nonredundantAngleDistances(angles))
        add(p.first, p.second);
    for (const pair<int, int>& p : extra)
        add(p.first, p.second);
    return result;
}

namespace {

/** The couplings among constraints [first, last) of pairs, ordered by their second constraint. */
vector<ConstraintCoupling> couplingsOf(const vector<pair<int, int>>& pairs, int first, int last, int numParticles) {
    vector<vector<int>> touching(numParticles);
    vector<ConstraintCoupling> result;
    for (int c = first; c < last; ++c)
        for (int end = 0; end < 2; ++end) {
            const int particle = end == 0 ? pairs[c].first : pairs[c].second;
            for (int d : touching[particle]) {
                const bool sameEnd = (pairs[d].first == particle) == (end == 0);
                result.push_back({d, c, particle, sameEnd ? 1.0 : -1.0});
            }
            touching[particle].push_back(c);
        }
    return result;
}

/** r / |r|, or 0 where r = 0. */
Vec3 unitDirection(const Vec3& r) {
    const double length = std::sqrt(r.dot(r));
    return length > 0 ? r / length : Vec3();
}

/**
 * |error| <= tolerance (|a| + |b|), the convergence test of a constraint's rate (error) whose particles move with
 * velocities a and b.  (|a| + |b|)^2 lies between s = |a|^2 + |b|^2 and 2 s, so the square roots are taken only
 * where those bounds leave the answer open.  Written so that a NaN counts as not converged.
 */
bool rateConverged(double error, const Vec3& a, const Vec3& b, double tolerance) {
    const double squares = a.dot(a), squareBound = tolerance * tolerance * (squares + b.dot(b));
    if (error * error <= squareBound)
        return true;
    if (error * error > 2 * squareBound)
        return false;
    return std::abs(error) <= tolerance * (std::sqrt(squares) + std::sqrt(b.dot(b)));
}

/**
 * Sets b to B = J M^-1 J^T of constraints [first, last) of pairs (rows numbered from first) with the unit directions
 * at positions, stored in directions[first, last); couplings are B's off-diagonal entries in the order b was built
 * with.  A constraint of length 0 gets direction 0.
 */
void assembleB(SparseLDLT& b, const vector<pair<int, int>>& pairs, int first, int last,
               const ConstraintCoupling* couplings, int numCouplings, const Vec3* positions,
               const double* inverseMasses, Vec3* directions) {
    for (int c = first; c < last; ++c) {
        const int i = pairs[c].first, j = pairs[c].second;
        directions[c] = unitDirection(positions[i] - positions[j]);
        b.setDiagonal(c - first, inverseMasses[i] + inverseMasses[j]);
    }
    for (int e = 0; e < numCouplings; ++e) {
        const ConstraintCoupling& coupling = couplings[e];
        b.setOffDiagonal(e, coupling.sign * inverseMasses[coupling.particle] *
                                directions[coupling.first].dot(directions[coupling.second]));
    }
}

} // namespace

vector<char> FlavorPlugin::independentConstraints(const vector<pair<int, int>>& pairs, const vector<char>& frozen,
                                                  const vector<double>& inverseMasses, const vector<Vec3>& positions,
                                                  double threshold) {
    const int n = (int)pairs.size();
    const vector<ConstraintCoupling> couplings = couplingsOf(pairs, 0, n, (int)positions.size());
    vector<pair<int, int>> offDiagonal;
    for (const ConstraintCoupling& coupling : couplings)
        offDiagonal.emplace_back(coupling.first, coupling.second);
    SparseLDLT rows(n, offDiagonal, false);
    vector<Vec3> directions(n);
    assembleB(rows, pairs, 0, n, couplings.data(), (int)couplings.size(), positions.data(), inverseMasses.data(),
              directions.data());
    rows.factorize(threshold);
    vector<char> keep(n);
    for (int c = 0; c < n; ++c)
        keep[c] = !frozen[c] || !rows.isDependent(c);
    return keep;
}

// The small helpers of the drift are defined inline: a shared library's exported functions are not inlined otherwise.
inline void FrozenDistances::addAlongConstraints(int first, int last, Vec3* x, const Vec3* u, const double* a,
                                                 double factor) const {
    for (int c = first; c < last; ++c) {
        const int i = pairs[c].first, j = pairs[c].second;
        const double amount = factor * a[c - first];
        x[i] += u[c] * (inverseMasses[i] * amount);
        x[j] -= u[c] * (inverseMasses[j] * amount);
    }
}

inline void FrozenDistances::addAlongConstraints(int k, Vec3* x, const Vec3* u, const double* a) const {
    addAlongConstraints(constraintStart[k], constraintStart[k + 1], x, u, a);
}

FrozenDistances::FrozenDistances(const System& system, const vector<pair<int, int>>& frozenPairs,
                                 const vector<Vec3>& positionsToCheck)
    : minItems(1), positionVector(nullptr), velocityVector(nullptr), positions(nullptr), velocities(nullptr),
      forces(nullptr), inverseMasses(nullptr), h(0.0), tolerance(0.0), kicking(false) {
    const int n = system.getNumParticles();
    vector<pair<int, int>> candidates;
    vector<char> candidateFrozen;
    std::set<pair<int, int>> constrained;
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        candidates.emplace_back(p1, p2);
        candidateFrozen.push_back(0);
        constrained.insert(ordered(p1, p2));
    }
    for (const pair<int, int>& p : frozenPairs) {
        if (system.getParticleMass(p.first) == 0.0 || system.getParticleMass(p.second) == 0.0)
            throw OpenMMException("FlavorIntegrator: the frozen distance between particles " + std::to_string(p.first) +
                                  " and " + std::to_string(p.second) +
                                  " involves a massless particle; massless particles do not move and cannot be "
                                  "frozen.  Move the force acting on it to a soft group");
        if (constrained.count(ordered(p.first, p.second)) == 0) {
            candidates.push_back(p);
            candidateFrozen.push_back(1);
        }
    }
    vector<double> particleInverseMasses(n);
    for (int i = 0; i < n; ++i)
        particleInverseMasses[i] = system.getParticleMass(i) == 0.0 ? 0.0 : 1.0 / system.getParticleMass(i);
    const vector<char> keep = independentConstraints(candidates, candidateFrozen, particleInverseMasses,
                                                     positionsToCheck, DependenceThreshold);
    vector<pair<int, int>> all;
    vector<double> allLengths;
    vector<bool> allFrozen;
    for (size_t c = 0; c < candidates.size(); ++c) {
        if (!keep[c])
            continue;
        all.push_back(candidates[c]);
        allFrozen.push_back(candidateFrozen[c] != 0);
        // The System's lengths; the frozen ones are set from the positions before each drift.
        double length = 0.0;
        if (c < (size_t)system.getNumConstraints()) {
            int p1, p2;
            system.getConstraintParameters((int)c, p1, p2, length);
        }
        allLengths.push_back(length);
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
    // Clusters without a frozen distance (rigid water, free particles) drift and are projected as in OpenMM's own
    // integrators, by the platform's constraint algorithms (SETTLE for water), in chunks of about ChunkParticles
    // particles that run in parallel; the cluster solver takes the rest, largest cluster first.
    vector<int> order(numClusters);
    for (int k = 0; k < numClusters; ++k)
        order[k] = k;
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return clusterConstraints[a].size() > clusterConstraints[b].size(); });
    std::unique_ptr<System> chunkSystem;
    auto closeChunk = [&]() {
        if (chunkSystem && chunkSystem->getNumConstraints() > 0)
            otherChunks.back().constraints = std::make_unique<ReferenceConstraints>(*chunkSystem);
        chunkSystem.reset();
    };
    particleStart.push_back(0);
    constraintStart.push_back(0);
    long long work = 0;
    for (int k : order) {
        const bool holdsFrozen = std::any_of(clusterConstraints[k].begin(), clusterConstraints[k].end(),
                                             [&](int c) { return allFrozen[c]; });
        if (!holdsFrozen) {
            if (!chunkSystem) {
                otherChunks.emplace_back();
                chunkSystem = std::make_unique<System>();
                for (int i = 0; i < n; ++i)
                    chunkSystem->addParticle(system.getParticleMass(i));
            }
            OtherChunk& chunk = otherChunks.back();
            for (int i : clusterParticles[k])
                (clusterConstraints[k].empty() ? chunk.freeParticles : chunk.constrainedParticles).push_back(i);
            for (int c : clusterConstraints[k])
                chunkSystem->addConstraint(all[c].first, all[c].second, allLengths[c]);
            work += (long long)clusterParticles[k].size();
            if ((int)(chunk.freeParticles.size() + chunk.constrainedParticles.size()) >= ChunkParticles)
                closeChunk();
            continue;
        }
        particles.insert(particles.end(), clusterParticles[k].begin(), clusterParticles[k].end());
        for (int c : clusterConstraints[k]) {
            pairs.push_back(all[c]);
            lengths.push_back(allLengths[c]);
            frozen.push_back(allFrozen[c] ? 1 : 0);
        }
        particleStart.push_back((int)particles.size());
        constraintStart.push_back((int)pairs.size());
        work += (long long)clusterConstraints[k].size();
    }
    closeChunk();
    numClusters = (int)particleStart.size() - 1;
    systemInverseMasses = particleInverseMasses;
    // A thread pool is worth waking for about 1024 constraints or particles per thread.
    const long long items = numClusters + (long long)otherChunks.size();
    minItems = (int)std::max(1LL, (1024 * items + std::max(1LL, work) - 1) / std::max(1LL, work));
    // B's pattern: constraints sharing a particle are coupled through it, and so lie in one cluster; listed by their
    // second constraint, the couplings come cluster by cluster.
    couplings = couplingsOf(pairs, 0, (int)pairs.size(), n);
    couplingStart.push_back(0);
    for (int k = 0; k < numClusters; ++k) {
        const int first = constraintStart[k], last = constraintStart[k + 1];
        vector<pair<int, int>> offDiagonal;
        size_t e = couplingStart.back();
        for (; e < couplings.size() && couplings[e].second < last; ++e)
            offDiagonal.emplace_back(couplings[e].first - first, couplings[e].second - first);
        couplingStart.push_back((int)e);
        solvers.emplace_back(last - first, offDiagonal);
        // The System's constraints come first in each cluster, and so do the couplings among them.  Every cluster
        // holds a frozen distance; one with System constraints too has a second solver for them.
        int numSystem = 0;
        for (int c = first; c < last; ++c)
            numSystem += frozen[c] ? 0 : 1;
        vector<pair<int, int>> systemOffDiagonal;
        for (const pair<int, int>& entry : offDiagonal)
            if (entry.second < numSystem)
                systemOffDiagonal.push_back(entry);
        systemCount.push_back(numSystem);
        systemCouplingCount.push_back((int)systemOffDiagonal.size());
        systemSolvers.emplace_back(numSystem, systemOffDiagonal);
    }
    targetRates.assign(pairs.size(), 0.0);
    residuals.assign(pairs.size(), 0.0);
    normalMomenta.assign(pairs.size(), 0.0);
    directions.resize(pairs.size());
    currentDirections.resize(pairs.size());
    previousPositions.resize(n);
    startPositions.resize(n);
    startVelocities.resize(n);
    scratch.resize(n);
    normalVelocities.resize(n);
    failed.assign(numClusters, 0);
    factorized.assign(numClusters, 0);
    rigid.assign(numClusters, 0);
    for (int k = 0; k < numClusters; ++k) {
        const int numParticles = particleStart[k + 1] - particleStart[k];
        rigidRank.push_back(numParticles == 2 ? 1 : 3 * numParticles - 6);
    }
    factorizedPositions.resize(n);
    // Which clusters hold normal momenta: those whose B is well conditioned where the set was chosen.
    holdsMomenta.assign(numClusters, 1);
    for (int k = 0; k < numClusters; ++k) {
        factorizeB(solvers[k], k, constraintStart[k + 1], couplingStart[k + 1] - couplingStart[k],
                   positionsToCheck.data(), particleInverseMasses.data());
        holdsMomenta[k] = solvers[k].smallestPivotRatio() >= MomentumConditioning ? 1 : 0;
    }
}

FrozenDistances::~FrozenDistances() = default;

void FrozenDistances::drift(vector<Vec3>& q, vector<Vec3>& v, const vector<double>& w, double step, double tol,
                            bool projectOthers, ParallelLoop& loop) {
    run(q, v, nullptr, w, step, tol, false, projectOthers, loop);
}

void FrozenDistances::kick(vector<Vec3>& q, vector<Vec3>& v, const vector<Vec3>& f, const vector<double>& w,
                           double step, double tol, bool projectOthers, ParallelLoop& loop) {
    run(q, v, &f, w, step, tol, true, projectOthers, loop);
}

void FrozenDistances::run(vector<Vec3>& q, vector<Vec3>& v, const vector<Vec3>* f, const vector<double>& w, double step,
                          double tol, bool kick, bool projectVelocitiesOfOthers, ParallelLoop& loop) {
    positionVector = &q;
    velocityVector = &v;
    positions = q.data();
    velocities = v.data();
    forces = f ? f->data() : nullptr;
    inverseMasses = w.data();
    h = step;
    tolerance = tol;
    kicking = kick;
    projectOthers = projectVelocitiesOfOthers;
    loop.run(*this, getNumClusters() + (int)otherChunks.size());
    checkConvergence();
}

std::string FrozenDistances::unstableMessage(double tolerance) {
    return "FlavorIntegrator: the frozen distances could not be held to the constraint tolerance " +
           std::to_string(tolerance) + " in " + std::to_string(MaxIterations) +
           " iterations; the simulation is unstable (reduce the mesostep)";
}

void FrozenDistances::checkConvergence() {
    for (size_t k = 0; k < failed.size(); ++k)
        if (failed[k]) {
            std::fill(failed.begin(), failed.end(), 0);
            throw OpenMMException(unstableMessage(tolerance));
        }
}

void FrozenDistances::apply(int begin, int end) const {
    const int numClusters = getNumClusters();
    for (int k = begin; k < end; ++k) {
        if (k >= numClusters)
            moveOtherChunk(otherChunks[k - numClusters]);
        else if (kicking)
            kickCluster(k);
        else
            driftCluster(k);
    }
}

void FrozenDistances::moveOtherChunk(const OtherChunk& chunk) const {
    vector<Vec3>& q = *positionVector;
    vector<Vec3>& v = *velocityVector;
    if (kicking) {
        for (const vector<int>* list : {&chunk.freeParticles, &chunk.constrainedParticles})
            for (int i : *list)
                v[i] += forces[i] * (h * inverseMasses[i]);
        // v satisfied the constraints before the kick, so projecting v projects the kick.
        if (chunk.constraints && projectOthers)
            chunk.constraints->applyToVelocities(q, v, systemInverseMasses, tolerance);
        return;
    }
    for (int i : chunk.freeParticles)
        q[i] += v[i] * h;
    if (!chunk.constraints)
        return;
    for (int i : chunk.constrainedParticles) {
        previousPositions[i] = q[i];
        q[i] += v[i] * h;
    }
    chunk.constraints->apply(previousPositions, q, systemInverseMasses, tolerance);
    const double inverseStep = 1.0 / h;
    for (int i : chunk.constrainedParticles)
        v[i] = (q[i] - previousPositions[i]) * inverseStep;
    if (projectOthers)
        chunk.constraints->applyToVelocities(q, v, systemInverseMasses, tolerance);
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
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
        const int i = particles[n];
        startPositions[i] = positions[i];
        startVelocities[i] = velocities[i];
    }
    // The constrained free flight in RATTLE steps: one if its Newton iteration converges, otherwise 2, 4, ... from
    // the start again (the flight turns the constraint directions less per step).
    for (int substeps = 1; substeps <= MaxSubsteps; substeps *= 2) {
        if (driftInSubsteps(k, substeps))
            return;
        for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
            const int i = particles[n];
            positions[i] = startPositions[i];
            velocities[i] = startVelocities[i];
        }
        // The directions stored where the failed flight went (rigid clusters keep B) are those of the start again.
        factorized[k] = 0;
    }
    failed[k] = 1;
}

bool FrozenDistances::driftInSubsteps(int k, int substeps) const {
    const double step = h / substeps;
    if (!factorizedHere(k))
        factorize(k);
    storeNormalMomenta(k);
    // The kinetic energy of the rates is given back below where the momenta are not held.
    const double startEnergy = holdsMomenta[k] ? 0.0 : normalKineticEnergy(k);
    // The normal part of the velocities is M^-1 J^T mu (with the System's constraints at rest): taken off here, the
    // projection only checks it, and refines where the System's constraints were not quite at rest.  Small clusters
    // only: the large ones (proteins) project as they always did.
    if (solvers[k].isDense())
        addAlongConstraints(constraintStart[k], constraintStart[k + 1], velocities, directions.data(),
                            &normalMomenta[constraintStart[k]], -1.0);
    if (!constrainVelocities(k, velocities, MaxIterations, true))
        return false;
    // A rigid cluster keeps the angles between its constraints, and so B and (1/2) mu^T B mu, everywhere on the
    // manifold: the force of the normal momenta is normal to it, and what its kicks add the projections that follow
    // take away again (along the directions there).  Its B need not be factorized again either, only the directions
    // follow the flight.
    const bool keepB = keepsShape(k);
    const bool turning = !keepB && holdsMomenta[k] && hasNormalMomenta(k);
    for (int s = 0; s < substeps; ++s) {
        // RATTLE on the constraint manifold with the potential (1/2) mu^T B(q) mu of the frozen normal momenta.
        if (turning)
            kickByNormalMomenta(k, 0.5 * step);
        for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
            const int i = particles[n];
            previousPositions[i] = positions[i];
            positions[i] += velocities[i] * step;
        }
        if (!constrainPositions(k))
            return false;
        for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
            const int i = particles[n];
            velocities[i] = (positions[i] - previousPositions[i]) * (1.0 / step);
        }
        // The factorization (a rigid cluster: the directions) here serves the next step, the normal momenta and the
        // kicks that follow the drift.
        if (keepB)
            storeDirections(k);
        else
            factorize(k);
        if (turning) {
            updateSystemMomenta(k);
            kickByNormalMomenta(k, 0.5 * step);
        }
        if (!constrainVelocities(k, velocities, MaxIterations, true))
            return false;
    }
    // The normal part comes back along the new directions: with the held momenta, or, where the momenta are ill
    // conditioned, as the stored rates (mu = B^-1 (0, rdot) with the new B) scaled by the one factor that keeps their
    // kinetic energy (1/2) rdot^T B^-1 rdot what it was at the start (1 where B did not change).
    double factor = 1.0;
    if (!holdsMomenta[k]) {
        storeNormalMomenta(k);
        const double endEnergy = normalKineticEnergy(k);
        factor = endEnergy > 0.0 ? std::sqrt(startEnergy / endEnergy) : 0.0;
    }
    addAlongConstraints(constraintStart[k], constraintStart[k + 1], velocities, directions.data(),
                        &normalMomenta[constraintStart[k]], factor);
    return true;
}

inline double FrozenDistances::normalKineticEnergy(int k) const {
    double energy = 0.0;
    for (int c = constraintStart[k]; c < constraintStart[k + 1]; ++c)
        energy += 0.5 * (frozen[c] ? targetRates[c] : 0.0) * normalMomenta[c];
    return energy;
}

inline void FrozenDistances::storeNormalMomenta(int k) const {
    // mu = B^-1 (0, rdot): the frozen distances' rates with the System's constraints at rest (B as just factorized).
    const int first = constraintStart[k], last = constraintStart[k + 1];
    double* mu = &normalMomenta[first];
    for (int c = first; c < last; ++c)
        mu[c - first] = frozen[c] ? targetRates[c] : 0.0;
    solvers[k].solve(mu);
}

inline bool FrozenDistances::hasNormalMomenta(int k) const {
    for (int c = constraintStart[k]; c < constraintStart[k + 1]; ++c)
        if (frozen[c] && normalMomenta[c] != 0.0)
            return true;
    return false;
}

void FrozenDistances::updateSystemMomenta(int k) const {
    // The System's constraints keep their rates 0 along the new directions: their entries of mu minimize
    // (1/2) mu^T B mu at fixed frozen entries, x = -B_ss^-1 B_sf mu_f.
    const int numSystem = systemCount[k];
    if (numSystem == 0)
        return;
    const int first = constraintStart[k], last = constraintStart[k + 1];
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n)
        normalVelocities[particles[n]] = Vec3();
    addAlongConstraints(first + numSystem, last, normalVelocities.data(), directions.data(),
                        &normalMomenta[first + numSystem]);
    factorizeB(systemSolvers[k], k, first + numSystem, systemCouplingCount[k], positions, inverseMasses);
    double* x = &normalMomenta[first];
    for (int c = first; c < first + numSystem; ++c)
        x[c - first] = -directions[c].dot(normalVelocities[pairs[c].first] - normalVelocities[pairs[c].second]);
    systemSolvers[k].solve(x);
}

void FrozenDistances::kickByNormalMomenta(int k, double dt) const {
    // F = -grad (1/2) mu^T B(q) mu at fixed mu, B = J M^-1 J^T with unit directions u_c: with the normal velocity
    // w = M^-1 J^T mu, constraint c = (a, b) of length L pulls a by -mu_c P_c (w_a - w_b) / L (P_c: the projection
    // perpendicular to u_c) and b by the opposite.  Directions as last factorized, i.e. at the current positions.
    const int first = constraintStart[k], last = constraintStart[k + 1];
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n)
        normalVelocities[particles[n]] = Vec3();
    addAlongConstraints(k, normalVelocities.data(), directions.data(), &normalMomenta[first]);
    for (int c = first; c < last; ++c) {
        const int a = pairs[c].first, b = pairs[c].second;
        const Vec3 u = directions[c];
        const Vec3 r = positions[a] - positions[b];
        const Vec3 relative = normalVelocities[a] - normalVelocities[b];
        const Vec3 force = (relative - u * u.dot(relative)) * (-normalMomenta[c] / std::sqrt(r.dot(r)));
        velocities[a] += force * (dt * inverseMasses[a]);
        velocities[b] -= force * (dt * inverseMasses[b]);
    }
}

void FrozenDistances::kickCluster(int k) const {
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
        const int i = particles[n];
        scratch[i] = forces[i] * (h * inverseMasses[i]);
    }
    // The factorization of the last drift is close to B here; a new one only when none exists yet.  A rigid
    // cluster's drift kept B from where it started: its kick factorizes where it is, so that what it does does not
    // depend on where the drift started (a Context whose state is set anew, a checkpoint rewound, forgets it).
    bool here = factorizedHere(k);
    if (!factorized[k] || (rigid[k] && !here)) {
        factorize(k);
        here = true;
    }
    if (!constrainVelocitiesRefactorizing(k, scratch.data(), here))
        failed[k] = 1;
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n) {
        const int i = particles[n];
        velocities[i] += scratch[i];
    }
}

inline void FrozenDistances::factorize(int k) const {
    const int numDependent = factorizeB(solvers[k], k, constraintStart[k + 1], couplingStart[k + 1] - couplingStart[k],
                                        positions, inverseMasses);
    rigid[k] = rigidShortcut && constraintStart[k + 1] - constraintStart[k] - numDependent == rigidRank[k] ? 1 : 0;
    factorized[k] = 1;
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n)
        factorizedPositions[particles[n]] = positions[particles[n]];
}

inline void FrozenDistances::storeDirections(int k) const {
    for (int c = constraintStart[k]; c < constraintStart[k + 1]; ++c)
        directions[c] = unitDirection(positions[pairs[c].first] - positions[pairs[c].second]);
}

inline bool FrozenDistances::keepsShape(int k) const {
    if (!rigid[k])
        return false;
    // The test of constrainPositions(): where a System constraint is off its length, the drift changes the shape.
    for (int c = constraintStart[k]; c < constraintStart[k] + systemCount[k]; ++c) {
        const Vec3 r = positions[pairs[c].first] - positions[pairs[c].second];
        const double target = lengths[c] * lengths[c];
        if (!(std::abs(target - r.dot(r)) <= 2 * tolerance * target))
            return false;
    }
    return true;
}

void FrozenDistances::forgetFactorizations() {
    std::fill(factorized.begin(), factorized.end(), 0);
}

inline bool FrozenDistances::factorizedHere(int k) const {
    // Kicks and thermostats between two drifts leave the positions, and so B and its directions, as they were.
    if (!factorized[k])
        return false;
    for (int n = particleStart[k]; n < particleStart[k + 1]; ++n)
        if (!(factorizedPositions[particles[n]] == positions[particles[n]]))
            return false;
    return true;
}

inline int FrozenDistances::factorizeB(SparseLDLT& solver, int k, int last, int numCouplings, const Vec3* q,
                                       const double* w) const {
    assembleB(solver, pairs, constraintStart[k], last, couplings.data() + couplingStart[k], numCouplings, q, w,
              directions.data());
    return solver.factorize(DependentPivot);
}

bool FrozenDistances::constrainPositions(int k) const {
    // Newton's iteration for |r_c|^2 = L_c^2 with corrections M^-1 J0^T lambda along the directions J0 at the start
    // of the drift: B lambda = (L^2 - r^2) / (2 L) to first order.
    const int first = constraintStart[k], last = constraintStart[k + 1];
    double* lambda = &residuals[first];
    for (int iteration = 0; iteration < MaxIterations; ++iteration) {
        bool converged = true;
        double largest = 0.0;
        for (int c = first; c < last; ++c) {
            const Vec3 r = positions[pairs[c].first] - positions[pairs[c].second];
            const double target = lengths[c] * lengths[c];
            const double difference = target - r.dot(r);
            // Rows found dependent hold when the others do; their residual is not theirs to remove.
            // Written so that a NaN counts as not converged.
            if (!(std::abs(difference) <= 2 * tolerance * target) && !solvers[k].isDependent(c - first))
                converged = false;
            lambda[c - first] = difference / (2 * lengths[c]);
            largest = std::max(largest, std::abs(difference) / target);
        }
        // Diverging (or NaN): give up early, the caller takes shorter steps.
        if (!(largest < MaxRelativeViolation))
            return false;
        if (converged)
            return true;
        solvers[k].solve(lambda);
        addAlongConstraints(k, positions, directions.data(), lambda);
    }
    return false;
}

bool FrozenDistances::constrainVelocitiesRefactorizing(int k, Vec3* v, bool directionsHere) const {
    // Refinement with B from elsewhere converges while the directions are close; if not, B from here.
    if (constrainVelocities(k, v, MaxIterations / 10, directionsHere))
        return true;
    factorize(k);
    return constrainVelocities(k, v, MaxIterations, true);
}

bool FrozenDistances::constrainVelocities(int k, Vec3* v, int maxIterations, bool directionsHere) const {
    // RATTLE's velocity step: (J M^-1 J^T) mu = -J v along the current unit directions J, by iterative refinement
    // with the factorized B (exact in one iteration where B was factorized).
    const int first = constraintStart[k], last = constraintStart[k + 1];
    double* mu = &residuals[first];
    const Vec3* u = directionsHere ? directions.data() : currentDirections.data();
    if (!directionsHere)
        for (int c = first; c < last; ++c) {
            const Vec3 r = positions[pairs[c].first] - positions[pairs[c].second];
            currentDirections[c] = r / std::sqrt(r.dot(r));
        }
    const pair<int, int>* ends = pairs.data();
    const SparseLDLT& solver = solvers[k];
    const double tol = tolerance;
    for (int iteration = 0; iteration < maxIterations; ++iteration) {
        bool converged = true;
        for (int c = first; c < last; ++c) {
            const Vec3 vi = v[ends[c].first], vj = v[ends[c].second];
            const double error = -u[c].dot(vi - vj);
            // Relative to the two speeds, not to their difference: where the pair moves as one (a rigid molecule
            // translating), its relative velocity is rounding of the speeds and cannot be resolved below them.
            if (!rateConverged(error, vi, vj, tol) && !solver.isDependent(c - first))
                converged = false;
            mu[c - first] = error;
        }
        if (converged)
            return true;
        solver.solve(mu);
        addAlongConstraints(k, v, u, mu);
    }
    return false;
}

bool FrozenDistances::describeSmallClusters(SmallClusterTable& table) const {
    using Table = SmallClusterTable;
    if (!rigidShortcut)
        return false;
    for (const OtherChunk& chunk : otherChunks)
        if (chunk.constraints || !chunk.constrainedParticles.empty())
            return false;
    for (int k = 0; k < getNumClusters(); ++k)
        if (systemCount[k] != 0 || !solvers[k].isDense() ||
            constraintStart[k + 1] - constraintStart[k] > Table::MaxConstraints ||
            particleStart[k + 1] - particleStart[k] > Table::MaxParticles)
            return false;
    Table result;
    for (int k = 0; k < getNumClusters(); ++k) {
        const int firstParticle = particleStart[k], numParticles = particleStart[k + 1] - firstParticle;
        const int firstConstraint = constraintStart[k], numConstraints = constraintStart[k + 1] - firstConstraint;
        auto local = [&](int particle) {
            return (int)(std::find(&particles[firstParticle], &particles[firstParticle] + numParticles, particle) -
                         &particles[firstParticle]);
        };
        for (int i = 0; i < Table::MaxParticles; ++i)
            result.particles.push_back(i < numParticles ? particles[firstParticle + i] : -1);
        for (int c = 0; c < Table::MaxConstraints; ++c) {
            const bool present = c < numConstraints;
            result.ends.push_back(present ? local(pairs[firstConstraint + c].first) : -1);
            result.ends.push_back(present ? local(pairs[firstConstraint + c].second) : -1);
            result.order.push_back(present ? solvers[k].eliminatedAt(c) : -1);
        }
        result.counts.insert(result.counts.end(), {numParticles, numConstraints, (int)holdsMomenta[k], 0});
    }
    for (const OtherChunk& chunk : otherChunks)
        result.freeParticles.insert(result.freeParticles.end(), chunk.freeParticles.begin(), chunk.freeParticles.end());
    table = std::move(result);
    return true;
}

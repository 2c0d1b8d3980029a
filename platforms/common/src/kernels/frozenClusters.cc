/**
 * The artificial FLAVOR's frozen stage on the device (DeviceFrozenStage): the frozen drift and kick of
 * FrozenDistances for clusters of at most MAX_CLUSTER_CONSTRAINTS frozen distances and no System constraint (a flexible
 * water molecule's triangle), one cluster per work-item, with the host's iterations, tests and dense elimination in
 * the same order, so that a double-precision trajectory follows the Reference one to rounding.  The work-items past the
 * clusters move the free particles.  A plain kick that runs just before (preKick, with the forces of its slot) is
 * applied first, in the same kernel.
 *
 * Each cluster keeps between calls what the host keeps: whether and where (relative to its first particle) B was last
 * factorized, B's pseudo-inverse G,
 * the unit directions last stored, the rows found dependent and whether the cluster was rigid there.  A cluster whose
 * drift does not converge in MAX_SUBSTEPS substeps sets failure[0] (the host reads it without waiting).
 *
 * Appended to flowPasses.cc (loadPosition, storePosition, applyKick, applyDrift, slotForce).
 */

#define MAX_CLUSTER_PARTICLES 5
#define MAX_CLUSTER_CONSTRAINTS 4
#define FROZEN_MAX_ITERATIONS 100
#define FROZEN_MAX_SUBSTEPS 16
#define FROZEN_MAX_RELATIVE_VIOLATION 0.1
#define FROZEN_DEPENDENT_PIVOT 1e-10
// Per cluster in clusterReals: G (MAX_C x MAX_C), the directions (3 MAX_C), where it was factorized (3 MAX_P).
#define CLUSTER_G_OFFSET 0
#define CLUSTER_DIRECTIONS_OFFSET (MAX_CLUSTER_CONSTRAINTS * MAX_CLUSTER_CONSTRAINTS)
#define CLUSTER_FACTORIZED_OFFSET (CLUSTER_DIRECTIONS_OFFSET + 3 * MAX_CLUSTER_CONSTRAINTS)
#define CLUSTER_REALS (CLUSTER_FACTORIZED_OFFSET + 3 * MAX_CLUSTER_PARTICLES)

typedef struct {
    int numParticles, numConstraints, holdsMomenta, factorized, rigid, dependent;
    int atom[MAX_CLUSTER_PARTICLES], a[MAX_CLUSTER_CONSTRAINTS], b[MAX_CLUSTER_CONSTRAINTS],
        order[MAX_CLUSTER_CONSTRAINTS];
    mixed w[MAX_CLUSTER_PARTICLES], q[MAX_CLUSTER_PARTICLES][3], v[MAX_CLUSTER_PARTICLES][3];
    mixed factorizedAt[MAX_CLUSTER_PARTICLES][3], u[MAX_CLUSTER_CONSTRAINTS][3],
        g[MAX_CLUSTER_CONSTRAINTS * MAX_CLUSTER_CONSTRAINTS];
    mixed length[MAX_CLUSTER_CONSTRAINTS], rate[MAX_CLUSTER_CONSTRAINTS], mu[MAX_CLUSTER_CONSTRAINTS];
    // The positions q are relative to origin (the first particle's where the cluster was loaded): in single precision
    // their differences and the chord velocities keep the digits that absolute coordinates would round away.
    mixed origin[3];
    mixed tolerance;
} FrozenCluster;

DEVICE mixed dot3(const mixed* x, const mixed* y) {
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
}

DEVICE void difference3(const mixed* x, const mixed* y, mixed* result) {
    for (int d = 0; d < 3; ++d)
        result[d] = x[d] - y[d];
}

DEVICE bool isDependent(const FrozenCluster* k, int c) {
    return (k->dependent >> c) & 1;
}

/** x = G x (SparseLDLT::solve on its dense path). */
DEVICE void solveB(const FrozenCluster* k, mixed* x) {
    const int n = k->numConstraints;
    mixed y[MAX_CLUSTER_CONSTRAINTS];
    for (int i = 0; i < n; ++i) {
        mixed sum = 0;
        for (int j = 0; j < n; ++j)
            sum += k->g[i * n + j] * x[j];
        y[i] = sum;
    }
    for (int i = 0; i < n; ++i)
        x[i] = y[i];
}

/** x_a += w_a u_c factor amount_c, x_b -= w_b u_c factor amount_c for every constraint c = (a, b). */
DEVICE void addAlongConstraints(const FrozenCluster* k, mixed (*x)[3], mixed (*u)[3], const mixed* amount,
                                mixed factor) {
    for (int c = 0; c < k->numConstraints; ++c) {
        const int i = k->a[c], j = k->b[c];
        const mixed scaled = factor * amount[c];
        const mixed si = k->w[i] * scaled, sj = k->w[j] * scaled;
        for (int d = 0; d < 3; ++d) {
            x[i][d] += u[c][d] * si;
            x[j][d] -= u[c][d] * sj;
        }
    }
}

/** r / |r|, or 0 where r = 0. */
DEVICE void unitDirection(const mixed* r, mixed* u) {
    const mixed length = sqrt(dot3(r, r));
    const mixed scale = length > 0 ? (mixed)1 / length : (mixed)0;
    for (int d = 0; d < 3; ++d)
        u[d] = length > 0 ? r[d] * scale : (mixed)0;
}

DEVICE void storeDirections(FrozenCluster* k) {
    for (int c = 0; c < k->numConstraints; ++c) {
        mixed r[3];
        difference3(k->q[k->a[c]], k->q[k->b[c]], r);
        unitDirection(r, k->u[c]);
    }
}

/** B = J M^-1 J^T at the current positions, eliminated in the host's order into G, its dependent rows and rigidity. */
DEVICE void factorize(FrozenCluster* k) {
    const int n = k->numConstraints;
    storeDirections(k);
    mixed full[MAX_CLUSTER_CONSTRAINTS][MAX_CLUSTER_CONSTRAINTS];
    for (int c = 0; c < n; ++c) {
        full[c][c] = k->w[k->a[c]] + k->w[k->b[c]];
        for (int e = 0; e < c; ++e) {
            // Coupled through a shared particle, with the sign of the product of their directions there.
            const int shared = (k->a[c] == k->a[e] || k->a[c] == k->b[e])   ? k->a[c]
                               : (k->b[c] == k->a[e] || k->b[c] == k->b[e]) ? k->b[c]
                                                                            : -1;
            mixed value = 0;
            if (shared >= 0) {
                const bool sameEnd = (k->a[e] == shared) == (k->a[c] == shared);
                value = (sameEnd ? (mixed)1 : (mixed)-1) * k->w[shared] * dot3(k->u[e], k->u[c]);
            }
            full[c][e] = value;
            full[e][c] = value;
        }
    }
    // SparseLDLT::eliminateDense: a is the permuted matrix, l the strict lower triangle of L, d the pivots.
    mixed a[MAX_CLUSTER_CONSTRAINTS][MAX_CLUSTER_CONSTRAINTS], l[MAX_CLUSTER_CONSTRAINTS][MAX_CLUSTER_CONSTRAINTS];
    mixed d[MAX_CLUSTER_CONSTRAINTS], keep[MAX_CLUSTER_CONSTRAINTS];
    for (int r = 0; r < n; ++r)
        for (int s = 0; s < n; ++s)
            a[r][s] = full[k->order[r]][k->order[s]];
    int numDependent = 0;
    k->dependent = 0;
    for (int r = 0; r < n; ++r) {
        mixed y[MAX_CLUSTER_CONSTRAINTS];
        for (int i = 0; i < r; ++i)
            y[i] = a[r][i];
        d[r] = a[r][r];
        for (int i = 0; i < r; ++i) {
            for (int s = i + 1; s < r; ++s)
                y[s] -= l[s][i] * y[i];
            const mixed entry = keep[i] != 0 ? y[i] / d[i] : (mixed)0;
            d[r] -= entry * y[i];
            l[r][i] = entry;
        }
        const bool dropped = d[r] <= (mixed)FROZEN_DEPENDENT_PIVOT * a[r][r];
        keep[r] = dropped ? 0 : 1;
        numDependent += dropped ? 1 : 0;
        if (dropped)
            k->dependent |= 1 << k->order[r];
    }
    mixed m[MAX_CLUSTER_CONSTRAINTS][MAX_CLUSTER_CONSTRAINTS], inversePivot[MAX_CLUSTER_CONSTRAINTS];
    for (int i = 0; i < n; ++i) {
        m[i][i] = 1;
        for (int j = 0; j < i; ++j) {
            mixed sum = 0;
            for (int s = j; s < i; ++s)
                sum -= l[i][s] * m[s][j];
            m[i][j] = sum;
        }
        inversePivot[i] = keep[i] != 0 ? (mixed)1 / d[i] : (mixed)0;
    }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j <= i; ++j) {
            mixed sum = 0;
            for (int s = i; s < n; ++s)
                sum += m[s][i] * inversePivot[s] * m[s][j];
            k->g[k->order[i] * n + k->order[j]] = sum;
            k->g[k->order[j] * n + k->order[i]] = sum;
        }
    const int rigidRank = k->numParticles == 2 ? 1 : 3 * k->numParticles - 6;
    k->rigid = n - numDependent == rigidRank;
    k->factorized = 1;
    for (int i = 0; i < k->numParticles; ++i)
        for (int c = 0; c < 3; ++c)
            k->factorizedAt[i][c] = k->q[i][c];
}

DEVICE bool factorizedHere(const FrozenCluster* k) {
    if (!k->factorized)
        return false;
    for (int i = 0; i < k->numParticles; ++i)
        for (int c = 0; c < 3; ++c)
            if (!(k->factorizedAt[i][c] == k->q[i][c]))
                return false;
    return true;
}

/** |error| <= tolerance (|a| + |b|), written so that a NaN counts as not converged (FrozenDistances' rateConverged). */
DEVICE bool rateConverged(mixed error, const mixed* a, const mixed* b, mixed tolerance) {
    const mixed squares = dot3(a, a), squareBound = tolerance * tolerance * (squares + dot3(b, b));
    if (error * error <= squareBound)
        return true;
    if (error * error > 2 * squareBound)
        return false;
    return fabs(error) <= tolerance * (sqrt(squares) + sqrt(dot3(b, b)));
}

/** Newton's iteration for |r_c|^2 = L_c^2 along the stored directions, with G as factorized. */
DEVICE bool constrainPositions(FrozenCluster* k) {
    mixed lambda[MAX_CLUSTER_CONSTRAINTS];
    for (int iteration = 0; iteration < FROZEN_MAX_ITERATIONS; ++iteration) {
        bool converged = true;
        mixed largest = 0;
        for (int c = 0; c < k->numConstraints; ++c) {
            mixed r[3];
            difference3(k->q[k->a[c]], k->q[k->b[c]], r);
            const mixed target = k->length[c] * k->length[c];
            const mixed difference = target - dot3(r, r);
            if (!(fabs(difference) <= 2 * k->tolerance * target) && !isDependent(k, c))
                converged = false;
            lambda[c] = difference / (2 * k->length[c]);
            largest = max(largest, fabs(difference) / target);
        }
        if (!(largest < (mixed)FROZEN_MAX_RELATIVE_VIOLATION))
            return false;
        if (converged)
            return true;
        solveB(k, lambda);
        addAlongConstraints(k, k->q, k->u, lambda, 1);
    }
    return false;
}

/** RATTLE's velocity step on x by refinement with G, along the stored directions or those at the positions. */
DEVICE bool constrainVelocities(FrozenCluster* k, mixed (*x)[3], int maxIterations, bool directionsHere) {
    mixed current[MAX_CLUSTER_CONSTRAINTS][3];
    if (!directionsHere)
        for (int c = 0; c < k->numConstraints; ++c) {
            mixed r[3];
            difference3(k->q[k->a[c]], k->q[k->b[c]], r);
            const mixed scale = (mixed)1 / sqrt(dot3(r, r));
            for (int d = 0; d < 3; ++d)
                current[c][d] = r[d] * scale;
        }
    mixed(*u)[3] = directionsHere ? k->u : current;
    mixed mu[MAX_CLUSTER_CONSTRAINTS];
    for (int iteration = 0; iteration < maxIterations; ++iteration) {
        bool converged = true;
        for (int c = 0; c < k->numConstraints; ++c) {
            mixed relative[3];
            difference3(x[k->a[c]], x[k->b[c]], relative);
            const mixed error = -dot3(u[c], relative);
            if (!rateConverged(error, x[k->a[c]], x[k->b[c]], k->tolerance) && !isDependent(k, c))
                converged = false;
            mu[c] = error;
        }
        if (converged)
            return true;
        solveB(k, mu);
        addAlongConstraints(k, x, u, mu, 1);
    }
    return false;
}

/** mu = G rdot: the normal momenta of the stored rates. */
DEVICE void storeNormalMomenta(FrozenCluster* k) {
    for (int c = 0; c < k->numConstraints; ++c)
        k->mu[c] = k->rate[c];
    solveB(k, k->mu);
}

DEVICE mixed normalKineticEnergy(const FrozenCluster* k) {
    mixed energy = 0;
    for (int c = 0; c < k->numConstraints; ++c)
        energy += (mixed)0.5 * k->rate[c] * k->mu[c];
    return energy;
}

/** v += dt M^-1 F with F = -grad (1/2) mu^T B(q) mu at fixed mu (FrozenDistances::kickByNormalMomenta). */
DEVICE void kickByNormalMomenta(FrozenCluster* k, mixed dt) {
    mixed normal[MAX_CLUSTER_PARTICLES][3];
    for (int i = 0; i < k->numParticles; ++i)
        for (int d = 0; d < 3; ++d)
            normal[i][d] = 0;
    addAlongConstraints(k, normal, k->u, k->mu, 1);
    for (int c = 0; c < k->numConstraints; ++c) {
        const int i = k->a[c], j = k->b[c];
        mixed r[3], relative[3];
        difference3(k->q[i], k->q[j], r);
        difference3(normal[i], normal[j], relative);
        const mixed along = dot3(k->u[c], relative), scale = -k->mu[c] / sqrt(dot3(r, r));
        const mixed si = dt * k->w[i], sj = dt * k->w[j];
        for (int d = 0; d < 3; ++d) {
            const mixed force = (relative[d] - k->u[c][d] * along) * scale;
            k->v[i][d] += force * si;
            k->v[j][d] -= force * sj;
        }
    }
}

/** The frozen drift of the cluster over h in substeps RATTLE steps (FrozenDistances::driftInSubsteps). */
DEVICE bool driftInSubsteps(FrozenCluster* k, mixed h, int substeps) {
    const mixed step = h / substeps;
    if (!factorizedHere(k))
        factorize(k);
    storeNormalMomenta(k);
    const mixed startEnergy = k->holdsMomenta ? (mixed)0 : normalKineticEnergy(k);
    addAlongConstraints(k, k->v, k->u, k->mu, -1);
    if (!constrainVelocities(k, k->v, FROZEN_MAX_ITERATIONS, true))
        return false;
    const bool keepB = k->rigid;
    bool anyMomentum = false;
    for (int c = 0; c < k->numConstraints; ++c)
        anyMomentum = anyMomentum || k->mu[c] != 0;
    const bool turning = !keepB && k->holdsMomenta && anyMomentum;
    for (int s = 0; s < substeps; ++s) {
        if (turning)
            kickByNormalMomenta(k, (mixed)0.5 * step);
        mixed previous[MAX_CLUSTER_PARTICLES][3];
        for (int i = 0; i < k->numParticles; ++i)
            for (int d = 0; d < 3; ++d) {
                previous[i][d] = k->q[i][d];
                k->q[i][d] += k->v[i][d] * step;
            }
        if (!constrainPositions(k))
            return false;
        const mixed inverseStep = (mixed)1 / step;
        for (int i = 0; i < k->numParticles; ++i)
            for (int d = 0; d < 3; ++d)
                k->v[i][d] = (k->q[i][d] - previous[i][d]) * inverseStep;
        if (keepB)
            storeDirections(k);
        else
            factorize(k);
        if (turning)
            kickByNormalMomenta(k, (mixed)0.5 * step);
        if (!constrainVelocities(k, k->v, FROZEN_MAX_ITERATIONS, true))
            return false;
    }
    mixed factor = 1;
    if (!k->holdsMomenta) {
        storeNormalMomenta(k);
        const mixed endEnergy = normalKineticEnergy(k);
        factor = endEnergy > 0 ? sqrt(startEnergy / endEnergy) : (mixed)0;
    }
    addAlongConstraints(k, k->v, k->u, k->mu, factor);
    return true;
}

DEVICE void preKickCluster(FrozenCluster* k, int index, GLOBAL const int* RESTRICT particles,
                           GLOBAL const mixed4* RESTRICT forces, GLOBAL const mm_long* RESTRICT forceBuffer,
                           int fromBuffer, mixed h) {
    for (int i = 0; i < k->numParticles; ++i) {
        mixed4 v = make_mixed4(k->v[i][0], k->v[i][1], k->v[i][2], k->w[i]);
        const int particle = particles[index * MAX_CLUSTER_PARTICLES + i];
        applyKick(&v, slotForce(forces, forceBuffer, fromBuffer, particle, k->atom[i]), h);
        k->v[i][0] = v.x;
        k->v[i][1] = v.y;
        k->v[i][2] = v.z;
    }
}

/** Reads cluster index's particles and the state it kept. */
DEVICE void loadCluster(FrozenCluster* k, int index, GLOBAL const int* RESTRICT particles,
                        GLOBAL const int* RESTRICT ends, GLOBAL const int* RESTRICT order,
                        GLOBAL const int4* RESTRICT counts, GLOBAL const int4* RESTRICT flags,
                        GLOBAL const mixed* RESTRICT reals, GLOBAL const int* RESTRICT slotOf,
                        GLOBAL const real4* RESTRICT posq, GLOBAL const real4* RESTRICT posqCorrection,
                        GLOBAL const mixed4* RESTRICT velm, mixed tolerance) {
    const int4 count = counts[index];
    const int4 flag = flags[index];
    k->numParticles = count.x;
    k->numConstraints = count.y;
    k->holdsMomenta = count.z;
    k->factorized = flag.x;
    k->rigid = flag.y;
    k->dependent = flag.z;
    k->tolerance = tolerance;
    for (int i = 0; i < k->numParticles; ++i) {
        const int atom = slotOf[particles[index * MAX_CLUSTER_PARTICLES + i]];
        k->atom[i] = atom;
        const mixed4 pos = loadPosition(posq, posqCorrection, atom);
        const mixed4 vel = velm[atom];
        if (i == 0) {
            k->origin[0] = pos.x;
            k->origin[1] = pos.y;
            k->origin[2] = pos.z;
        }
        k->q[i][0] = pos.x - k->origin[0];
        k->q[i][1] = pos.y - k->origin[1];
        k->q[i][2] = pos.z - k->origin[2];
        k->v[i][0] = vel.x;
        k->v[i][1] = vel.y;
        k->v[i][2] = vel.z;
        k->w[i] = vel.w;
    }
    const int n = k->numConstraints;
    for (int c = 0; c < n; ++c) {
        k->a[c] = ends[index * 2 * MAX_CLUSTER_CONSTRAINTS + 2 * c];
        k->b[c] = ends[index * 2 * MAX_CLUSTER_CONSTRAINTS + 2 * c + 1];
        k->order[c] = order[index * MAX_CLUSTER_CONSTRAINTS + c];
    }
    GLOBAL const mixed* kept = reals + index * CLUSTER_REALS;
    for (int e = 0; e < n * n; ++e)
        k->g[e] = kept[CLUSTER_G_OFFSET + e];
    for (int c = 0; c < n; ++c)
        for (int d = 0; d < 3; ++d)
            k->u[c][d] = kept[CLUSTER_DIRECTIONS_OFFSET + 3 * c + d];
    for (int i = 0; i < k->numParticles; ++i)
        for (int d = 0; d < 3; ++d)
            k->factorizedAt[i][d] = kept[CLUSTER_FACTORIZED_OFFSET + 3 * i + d];
}

/** Writes the state the cluster keeps, and its positions (if moved) and velocities. */
DEVICE void storeCluster(const FrozenCluster* k, int index, bool moved, GLOBAL int4* RESTRICT flags,
                         GLOBAL mixed* RESTRICT reals, GLOBAL real4* RESTRICT posq,
                         GLOBAL real4* RESTRICT posqCorrection, GLOBAL mixed4* RESTRICT velm) {
    flags[index] = make_int4(k->factorized, k->rigid, k->dependent, 0);
    GLOBAL mixed* kept = reals + index * CLUSTER_REALS;
    const int n = k->numConstraints;
    for (int e = 0; e < n * n; ++e)
        kept[CLUSTER_G_OFFSET + e] = k->g[e];
    for (int c = 0; c < n; ++c)
        for (int d = 0; d < 3; ++d)
            kept[CLUSTER_DIRECTIONS_OFFSET + 3 * c + d] = k->u[c][d];
    for (int i = 0; i < k->numParticles; ++i) {
        for (int d = 0; d < 3; ++d)
            kept[CLUSTER_FACTORIZED_OFFSET + 3 * i + d] = k->factorizedAt[i][d];
        const int atom = k->atom[i];
        if (moved) {
            mixed4 pos = loadPosition(posq, posqCorrection, atom);
            pos.x = k->origin[0] + k->q[i][0];
            pos.y = k->origin[1] + k->q[i][1];
            pos.z = k->origin[2] + k->q[i][2];
            storePosition(posq, posqCorrection, atom, pos);
        }
        mixed4 vel = velm[atom];
        vel.x = k->v[i][0];
        vel.y = k->v[i][1];
        vel.z = k->v[i][2];
        velm[atom] = vel;
    }
}

/**
 * The frozen drift over h (FrozenDistances::drift): clusters [0, numClusters), then the free particles.  A cluster
 * that cannot be held in FROZEN_MAX_SUBSTEPS substeps is put back where it started and sets failure[0].
 */
KERNEL void frozenDrift(int numClusters, int numFree, GLOBAL const int* RESTRICT particles,
                        GLOBAL const int* RESTRICT ends, GLOBAL const int* RESTRICT order,
                        GLOBAL const int4* RESTRICT counts, GLOBAL int4* RESTRICT flags, GLOBAL mixed* RESTRICT reals,
                        GLOBAL const int* RESTRICT freeParticles, GLOBAL const int* RESTRICT slotOf,
                        GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                        GLOBAL mixed4* RESTRICT velm, GLOBAL int* RESTRICT failure, mixed h, mixed tolerance,
                        GLOBAL const mixed4* RESTRICT preKickForces, GLOBAL const mm_long* RESTRICT forceBuffer,
                        int preKickFromBuffer, mixed preKick) {
    for (int item = GLOBAL_ID; item < numClusters + numFree; item += GLOBAL_SIZE) {
        if (item >= numClusters) {
            const int particle = freeParticles[item - numClusters];
            const int atom = slotOf[particle];
            mixed4 v = velm[atom];
            if (preKick != 0) {
                applyKick(&v, slotForce(preKickForces, forceBuffer, preKickFromBuffer, particle, atom), preKick);
                velm[atom] = v;
            }
            mixed4 pos = loadPosition(posq, posqCorrection, atom);
            applyDrift(&pos, v, h);
            storePosition(posq, posqCorrection, atom, pos);
            continue;
        }
        FrozenCluster k;
        loadCluster(&k, item, particles, ends, order, counts, flags, reals, slotOf, posq, posqCorrection, velm,
                    tolerance);
        if (preKick != 0)
            preKickCluster(&k, item, particles, preKickForces, forceBuffer, preKickFromBuffer, preKick);
        mixed startQ[MAX_CLUSTER_PARTICLES][3], startV[MAX_CLUSTER_PARTICLES][3];
        for (int c = 0; c < k.numConstraints; ++c) {
            mixed r[3], relative[3];
            difference3(k.q[k.a[c]], k.q[k.b[c]], r);
            difference3(k.v[k.a[c]], k.v[k.b[c]], relative);
            k.length[c] = sqrt(dot3(r, r));
            k.rate[c] = dot3(r, relative) / k.length[c];
        }
        for (int i = 0; i < k.numParticles; ++i)
            for (int d = 0; d < 3; ++d) {
                startQ[i][d] = k.q[i][d];
                startV[i][d] = k.v[i][d];
            }
        bool held = false;
        for (int substeps = 1; substeps <= FROZEN_MAX_SUBSTEPS && !held; substeps *= 2) {
            held = driftInSubsteps(&k, h, substeps);
            if (!held) {
                for (int i = 0; i < k.numParticles; ++i)
                    for (int d = 0; d < 3; ++d) {
                        k.q[i][d] = startQ[i][d];
                        k.v[i][d] = startV[i][d];
                    }
                k.factorized = 0;
            }
        }
        if (!held)
            failure[0] = 1;
        storeCluster(&k, item, true, flags, reals, posq, posqCorrection, velm);
    }
}

/**
 * The frozen kick v += h P M^-1 F (FrozenDistances::kick) with the forces of a slot (system order): clusters, then the
 * free particles.
 */
KERNEL void frozenKick(int numClusters, int numFree, GLOBAL const int* RESTRICT particles,
                       GLOBAL const int* RESTRICT ends, GLOBAL const int* RESTRICT order,
                       GLOBAL const int4* RESTRICT counts, GLOBAL int4* RESTRICT flags, GLOBAL mixed* RESTRICT reals,
                       GLOBAL const int* RESTRICT freeParticles, GLOBAL const int* RESTRICT slotOf,
                       GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection, GLOBAL mixed4* RESTRICT velm,
                       GLOBAL int* RESTRICT failure, GLOBAL const mixed4* RESTRICT forces, mixed h, mixed tolerance,
                       GLOBAL const mixed4* RESTRICT preKickForces, GLOBAL const mm_long* RESTRICT forceBuffer,
                       int preKickFromBuffer, mixed preKick) {
    for (int item = GLOBAL_ID; item < numClusters + numFree; item += GLOBAL_SIZE) {
        if (item >= numClusters) {
            const int particle = freeParticles[item - numClusters];
            const int atom = slotOf[particle];
            mixed4 v = velm[atom];
            if (preKick != 0)
                applyKick(&v, slotForce(preKickForces, forceBuffer, preKickFromBuffer, particle, atom), preKick);
            applyKick(&v, forces[particle], h);
            velm[atom] = v;
            continue;
        }
        FrozenCluster k;
        loadCluster(&k, item, particles, ends, order, counts, flags, reals, slotOf, posq, posqCorrection, velm,
                    tolerance);
        if (preKick != 0)
            preKickCluster(&k, item, particles, preKickForces, forceBuffer, preKickFromBuffer, preKick);
        mixed impulse[MAX_CLUSTER_PARTICLES][3];
        for (int i = 0; i < k.numParticles; ++i) {
            const mixed4 f = forces[particles[item * MAX_CLUSTER_PARTICLES + i]];
            const mixed scale = h * k.w[i];
            impulse[i][0] = f.x * scale;
            impulse[i][1] = f.y * scale;
            impulse[i][2] = f.z * scale;
        }
        // A rigid cluster's drift kept B from where it started: its kick factorizes where it is.
        bool here = factorizedHere(&k);
        if (!k.factorized || (k.rigid && !here)) {
            factorize(&k);
            here = true;
        }
        bool projected = constrainVelocities(&k, impulse, FROZEN_MAX_ITERATIONS / 10, here);
        if (!projected) {
            factorize(&k);
            projected = constrainVelocities(&k, impulse, FROZEN_MAX_ITERATIONS, true);
        }
        if (!projected)
            failure[0] = 1;
        for (int i = 0; i < k.numParticles; ++i)
            for (int d = 0; d < 3; ++d)
                k.v[i][d] += impulse[i][d];
        storeCluster(&k, item, false, flags, reals, posq, posqCorrection, velm);
    }
}

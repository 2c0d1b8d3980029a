/**
 * The System's constraints around the SIM's stiff flows on the device (DeviceCarriedConstraints), the arithmetic of
 * the host's ConstraintProjector: a stiff flow writes its displacement into posDelta (and a copy into uncorrected)
 * with each carrier's inverse mass set to its solve's, OpenMM's SETTLE corrects the displacement, and the kernels here
 * put the corrected positions in place, change the velocities by the corrections and move the other particles of each
 * carried component by their motions per correction of its carrier (a constrained particle of a stiff component).
 *
 * Per pass: carriers (system order, one per carried component k); motionStart, three runs of numCarried + 1 offsets
 * into motionParticle for the position motions, the velocity motions after a velocity solve and the velocity
 * processing of a step's last Filtered kick; carrierReals, 21 per carrier: the inverse masses of the position solve,
 * the velocity solve and its own, then the impulses per unit position correction and per unit velocity correction
 * (3 x 3, row-major); motionReals, 18 per position motion (position, then velocity per unit correction) and 9 per
 * velocity or processing motion after them (numPositionMotions). stepImpulses accumulate the carriers' impulses of a
 * step (firstOfStep: the pass that starts them); carrierVelocity holds each carrier's velocity before a velocity
 * solve; applied (system order) the velocity processing still on the velocities.
 */

/** out = m v for a row-major 3 x 3 matrix m, rounded as the host's product. */
DEVICE mixed4 carriedProduct(GLOBAL const mixed* RESTRICT m, mixed4 v) {
    return make_mixed4(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
                       m[6] * v.x + m[7] * v.y + m[8] * v.z, 0);
}

/** a + b in x, y and z; a's w kept. */
DEVICE mixed4 plus3(mixed4 a, mixed4 b) {
    return make_mixed4(a.x + b.x, a.y + b.y, a.z + b.z, a.w);
}

/** stepImpulses[k] += m correction, or = where the step's impulses start. */
DEVICE void addCarrierImpulse(GLOBAL mixed4* RESTRICT stepImpulses, int k, GLOBAL const mixed* RESTRICT m,
                              mixed4 correction, int firstOfStep) {
    const mixed4 impulse = carriedProduct(m, correction);
    if (firstOfStep) {
        stepImpulses[k] = impulse;
    } else {
        mixed4 sum = stepImpulses[k];
        sum = plus3(sum, impulse);
        stepImpulses[k] = sum;
    }
}

/**
 * The displacement as corrected, into the positions; the velocity changed by velocityScale per unit correction.
 * Returns the new velocity (stored by the caller) and the correction.
 */
DEVICE mixed4 placeCorrected(GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                             GLOBAL const mixed4* RESTRICT velm, GLOBAL const mixed4* RESTRICT posDelta,
                             GLOBAL const mixed4* RESTRICT uncorrected, int atom, mixed velocityScale, mixed4* pos,
                             mixed4* correction) {
    *pos = loadPosition(posq, posqCorrection, atom);
    const mixed4 delta = posDelta[atom];
    const mixed4 before = uncorrected[atom];
    pos->x += delta.x;
    pos->y += delta.y;
    pos->z += delta.z;
    *correction = make_mixed4(delta.x - before.x, delta.y - before.y, delta.z - before.z, 0);
    mixed4 vel = velm[atom];
    if (vel.w != 0) {
        vel.x += correction->x * velocityScale;
        vel.y += correction->y * velocityScale;
        vel.z += correction->z * velocityScale;
    }
    return vel;
}

/**
 * After SETTLE corrected a stiff flow's displacement: every particle at its corrected position, the other particles
 * of carried components moved by their carrier's correction, the carriers' impulses added up, and each carrier's
 * inverse mass that of the velocity solve (velocitySolveNext) or its own.
 */
KERNEL void finishCarriedPositions(int numAtoms, GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                                   GLOBAL mixed4* RESTRICT velm, GLOBAL const mixed4* RESTRICT posDelta,
                                   GLOBAL const mixed4* RESTRICT uncorrected, GLOBAL const int* RESTRICT atomIndex,
                                   GLOBAL const int* RESTRICT slotOf, GLOBAL const int* RESTRICT carriedMember,
                                   mixed velocityScale, int numCarried, GLOBAL const int* RESTRICT carriers,
                                   GLOBAL const int* RESTRICT motionStart, GLOBAL const int* RESTRICT motionParticle,
                                   GLOBAL const mixed* RESTRICT carrierReals, GLOBAL const mixed* RESTRICT motionReals,
                                   GLOBAL mixed4* RESTRICT stepImpulses, GLOBAL mixed4* RESTRICT carrierVelocity,
                                   int firstOfStep, int velocitySolveNext) {
    // Particles outside carried components here (massless ones do not move: the flow left their posDelta alone); the
    // components' particles below, each by one work-item.
    for (int atom = GLOBAL_ID; atom < numAtoms; atom += GLOBAL_SIZE) {
        if (carriedMember[atomIndex[atom]] || velm[atom].w == 0)
            continue;
        mixed4 pos, correction;
        velm[atom] =
            placeCorrected(posq, posqCorrection, velm, posDelta, uncorrected, atom, velocityScale, &pos, &correction);
        storePosition(posq, posqCorrection, atom, pos);
    }
    for (int k = GLOBAL_ID; k < numCarried; k += GLOBAL_SIZE) {
        const int carrier = carriers[k];
        const int carrierAtom = slotOf[carrier];
        const mixed4 delta = posDelta[carrierAtom], before = uncorrected[carrierAtom];
        const mixed4 carrierCorrection = make_mixed4(delta.x - before.x, delta.y - before.y, delta.z - before.z, 0);
        GLOBAL const mixed* own = carrierReals + 21 * k;
        addCarrierImpulse(stepImpulses, k, own + 3, carrierCorrection, firstOfStep);
        for (int j = motionStart[k]; j < motionStart[k + 1]; ++j) {
            const int particle = motionParticle[j];
            const int atom = slotOf[particle];
            GLOBAL const mixed* m = motionReals + 18 * j;
            mixed4 pos, correction;
            mixed4 vel = placeCorrected(posq, posqCorrection, velm, posDelta, uncorrected, atom, velocityScale, &pos,
                                        &correction);
            if (particle != carrier) {
                const mixed4 move = carriedProduct(m, carrierCorrection);
                pos = plus3(pos, move);
            }
            const mixed4 change = carriedProduct(m + 9, carrierCorrection);
            vel = plus3(vel, change);
            storePosition(posq, posqCorrection, atom, pos);
            velm[atom] = vel;
        }
        mixed4 vel = velm[carrierAtom];
        vel.w = velocitySolveNext ? own[1] : own[2];
        velm[carrierAtom] = vel;
        carrierVelocity[k] = vel;
    }
}

/**
 * Before a velocity solve that ends a step with a Filtered kick (run by forceResponse for the carrier's component):
 * the velocity processing of the step's impulses (process), recorded in applied; carrier k (at carrierAtom) has its
 * velocity remembered and its inverse mass that of the solve.
 */
DEVICE void prepareCarrier(int k, int carrierAtom, int numCarried, GLOBAL mixed4* RESTRICT velm,
                           GLOBAL const int* RESTRICT slotOf, GLOBAL const int* RESTRICT motionStart,
                           GLOBAL const int* RESTRICT motionParticle, GLOBAL const mixed* RESTRICT carrierReals,
                           GLOBAL const mixed* RESTRICT motionReals, int numPositionMotions,
                           GLOBAL const mixed4* RESTRICT stepImpulses, GLOBAL mixed4* RESTRICT carrierVelocity,
                           GLOBAL mixed4* RESTRICT applied, int process) {
    GLOBAL const int* processingStart = motionStart + 2 * (numCarried + 1);
    if (process) {
        const mixed4 impulse = stepImpulses[k];
        for (int j = processingStart[k]; j < processingStart[k + 1]; ++j) {
            const int particle = motionParticle[j];
            const int atom = slotOf[particle];
            const mixed4 change =
                carriedProduct(motionReals + 18 * numPositionMotions + 9 * (j - numPositionMotions), impulse);
            mixed4 vel = velm[atom];
            vel = plus3(vel, change);
            velm[atom] = vel;
            mixed4 sum = applied[particle];
            sum = plus3(sum, change);
            applied[particle] = sum;
        }
    }
    mixed4 vel = velm[carrierAtom];
    vel.w = carrierReals[21 * k + 1];
    velm[carrierAtom] = vel;
    carrierVelocity[k] = vel;
}

/**
 * After a velocity solve with the carriers' solve masses: the carriers' impulses added up, the other particles of
 * their components moved by their velocity motions, and each carrier's own inverse mass back.
 */
KERNEL void finishCarriedVelocities(int numCarried, GLOBAL mixed4* RESTRICT velm, GLOBAL const int* RESTRICT slotOf,
                                    GLOBAL const int* RESTRICT carriers, GLOBAL const int* RESTRICT motionStart,
                                    GLOBAL const int* RESTRICT motionParticle,
                                    GLOBAL const mixed* RESTRICT carrierReals, GLOBAL const mixed* RESTRICT motionReals,
                                    int numPositionMotions, GLOBAL mixed4* RESTRICT stepImpulses,
                                    GLOBAL const mixed4* RESTRICT carrierVelocity, int firstOfStep) {
    GLOBAL const int* velocityStart = motionStart + numCarried + 1;
    for (int k = GLOBAL_ID; k < numCarried; k += GLOBAL_SIZE) {
        const int carrierAtom = slotOf[carriers[k]];
        mixed4 vel = velm[carrierAtom];
        const mixed4 before = carrierVelocity[k];
        const mixed4 correction = make_mixed4(vel.x - before.x, vel.y - before.y, vel.z - before.z, 0);
        GLOBAL const mixed* own = carrierReals + 21 * k;
        addCarrierImpulse(stepImpulses, k, own + 12, correction, firstOfStep);
        for (int j = velocityStart[k]; j < velocityStart[k + 1]; ++j) {
            const int atom = slotOf[motionParticle[j]];
            const mixed4 change =
                carriedProduct(motionReals + 18 * numPositionMotions + 9 * (j - numPositionMotions), correction);
            mixed4 moved = velm[atom];
            moved = plus3(moved, change);
            velm[atom] = moved;
        }
        vel.w = own[2];
        velm[carrierAtom] = vel;
    }
}

/**
 * Where a step starts: the last step's velocity processing (applied, zeroed) taken off the velocities (where the
 * step's first pass is not a stiff flow, which does it itself).
 */
KERNEL void takeOffCarriedProcessing(int numAtoms, GLOBAL mixed4* RESTRICT velm, GLOBAL const int* RESTRICT atomIndex,
                                     GLOBAL mixed4* RESTRICT applied) {
    for (int atom = GLOBAL_ID; atom < numAtoms; atom += GLOBAL_SIZE) {
        const int particle = atomIndex[atom];
        const mixed4 a = applied[particle];
        if (a.x == 0 && a.y == 0 && a.z == 0)
            continue;
        mixed4 vel = velm[atom];
        vel.x -= a.x;
        vel.y -= a.y;
        vel.z -= a.z;
        velm[atom] = vel;
        applied[particle] = make_mixed4(0, 0, 0, 0);
    }
}

/**
 * The particle flows of the step engine on OpenMM's common compute platforms, in the common kernel language: kicks,
 * drifts, Ornstein-Uhlenbeck flows, and the exact stiff flow and the force responses of the Filtered and Warped
 * splittings of one component per work-item, with the counter-based normals of
 * openmmapi/include/internal/CounterRandom.h (Philox4x32-10 and the same ziggurat), so that a double-precision
 * trajectory follows the Reference platform's to rounding.
 *
 * Arrays indexed by particle in the System's order are marked "system order"; posq, velm and the force buffer are in
 * the Context's atom order, and atomIndex maps an atom to its particle (slotOf the other way).
 *
 * Defines: NUM_ATOMS, PADDED_NUM_ATOMS.
 */

#ifdef __OPENCL_VERSION__
// Each product and sum rounded as the CPU engine rounds it.
#pragma OPENCL FP_CONTRACT OFF
#endif

#define ZIGGURAT_TAIL_START ((mixed)3.442619855899)
#define FORCE_SCALE ((mixed)(1.0 / 4294967296.0))
#define MAX_SMALL_SIZE 18

/** Philox4x32-10 (Salmon et al., SC'11) of the counter c with the key (k0, k1), in place. */
DEVICE void philox4x32(unsigned int* c, unsigned int k0, unsigned int k1) {
    for (int round = 0; round < 10; ++round) {
        const mm_ulong p0 = (mm_ulong)0xD2511F53u * c[0];
        const mm_ulong p1 = (mm_ulong)0xCD9E8D57u * c[2];
        const unsigned int c0 = (unsigned int)(p1 >> 32) ^ c[1] ^ k0;
        const unsigned int c1 = (unsigned int)p1;
        const unsigned int c2 = (unsigned int)(p0 >> 32) ^ c[3] ^ k1;
        const unsigned int c3 = (unsigned int)p0;
        c[0] = c0;
        c[1] = c1;
        c[2] = c2;
        c[3] = c3;
        k0 += 0x9E3779B9u;
        k1 += 0xBB67AE85u;
    }
}

/** Further random words of one counter, one block at a time (CounterRandom's Spare). */
typedef struct {
    unsigned int counter[4], words[4];
    int used;
    unsigned int k0, k1;
} SpareWords;

DEVICE unsigned int nextSpareWord(SpareWords* spare) {
    if (spare->used == 4) {
        spare->counter[3]++;
        for (int k = 0; k < 4; ++k)
            spare->words[k] = spare->counter[k];
        philox4x32(spare->words, spare->k0, spare->k1);
        spare->used = 0;
    }
    return spare->words[spare->used++];
}

DEVICE mixed uniformOpen(unsigned int x) {
    return ((mixed)x + (mixed)0.5) * (mixed)(1.0 / 4294967296.0);
}

/** One standard normal number from a signed 32-bit value and a layer by the 128-layer ziggurat. */
DEVICE mixed zigguratNormal(int value, unsigned int layer, SpareWords* spare, GLOBAL const unsigned int* RESTRICT kn,
                            GLOBAL const mixed* RESTRICT wn, GLOBAL const mixed* RESTRICT fn) {
    while (true) {
        const mm_long magnitude = value < 0 ? -(mm_long)value : (mm_long)value;
        const mixed x = (mixed)value * wn[layer];
        if (magnitude < (mm_long)kn[layer])
            return x;
        if (layer == 0) {
            mixed tailX, tailY;
            do {
                tailX = -log(uniformOpen(nextSpareWord(spare))) / ZIGGURAT_TAIL_START;
                tailY = -log(uniformOpen(nextSpareWord(spare)));
            } while (tailY + tailY < tailX * tailX);
            return value > 0 ? ZIGGURAT_TAIL_START + tailX : -ZIGGURAT_TAIL_START - tailX;
        }
        if (fn[layer] + uniformOpen(nextSpareWord(spare)) * (fn[layer - 1] - fn[layer]) < exp((mixed)-0.5 * x * x))
            return x;
        value = (int)nextSpareWord(spare);
        layer = nextSpareWord(spare) & 127;
    }
}

/** The three normal numbers of one particle in one stream (CounterRandom::normals). */
DEVICE void counterNormals(mm_ulong stream, unsigned int particle, unsigned int k0, unsigned int k1,
                           GLOBAL const unsigned int* RESTRICT kn, GLOBAL const mixed* RESTRICT wn,
                           GLOBAL const mixed* RESTRICT fn, mixed* result) {
    unsigned int bits[4] = {(unsigned int)stream, (unsigned int)(stream >> 32), particle, 0};
    philox4x32(bits, k0, k1);
    SpareWords spare;
    spare.counter[0] = (unsigned int)stream;
    spare.counter[1] = (unsigned int)(stream >> 32);
    spare.counter[2] = particle;
    spare.counter[3] = 0;
    spare.used = 4;
    spare.k0 = k0;
    spare.k1 = k1;
    for (int k = 0; k < 3; ++k)
        result[k] = zigguratNormal((int)bits[k], (bits[3] >> (7 * k)) & 127, &spare, kn, wn, fn);
}

DEVICE mixed4 loadPosition(GLOBAL const real4* RESTRICT posq, GLOBAL const real4* RESTRICT posqCorrection, int atom) {
#ifdef USE_MIXED_PRECISION
    const real4 p1 = posq[atom];
    const real4 p2 = posqCorrection[atom];
    return make_mixed4(p1.x + (mixed)p2.x, p1.y + (mixed)p2.y, p1.z + (mixed)p2.z, p1.w);
#else
    return posq[atom];
#endif
}

DEVICE void storePosition(GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection, int atom, mixed4 pos) {
#ifdef USE_MIXED_PRECISION
    posq[atom] = make_real4((real)pos.x, (real)pos.y, (real)pos.z, (real)pos.w);
    posqCorrection[atom] = make_real4(pos.x - (real)pos.x, pos.y - (real)pos.y, pos.z - (real)pos.z, 0);
#else
    posq[atom] = pos;
#endif
}

/** v += h M^-1 F, v.w being the inverse mass: the arithmetic of every kick on the device. */
DEVICE void applyKick(mixed4* v, mixed4 f, mixed h) {
    const mixed scale = h * v->w;
    v->x += scale * f.x;
    v->y += scale * f.y;
    v->z += scale * f.z;
}

/** q += h v. */
DEVICE void applyDrift(mixed4* pos, mixed4 v, mixed h) {
    pos->x += h * v.x;
    pos->y += h * v.y;
    pos->z += h * v.z;
}

/** The exact Ornstein-Uhlenbeck flow v = decay v + scale xi (scale: noise sqrt(kT/m)). */
DEVICE void applyThermostat(mixed4* v, const mixed* xi, mixed decay, mixed scale) {
    v->x = v->x * decay + xi[0] * scale;
    v->y = v->y * decay + xi[1] * scale;
    v->z = v->z * decay + xi[2] * scale;
}

/**
 * A particle's forces: from the platform's fixed-point force buffer (atom order) where fromBuffer (forces evaluated and
 * not yet copied into their slot), else from a force slot (system order); the same values either way.
 */
DEVICE mixed4 slotForce(GLOBAL const mixed4* RESTRICT slot, GLOBAL const mm_long* RESTRICT buffer, int fromBuffer,
                        int particle, int atom) {
    if (fromBuffer)
        return make_mixed4(FORCE_SCALE * (mixed)buffer[atom], FORCE_SCALE * (mixed)buffer[atom + PADDED_NUM_ATOMS],
                           FORCE_SCALE * (mixed)buffer[atom + 2 * PADDED_NUM_ATOMS], 0);
    return slot[particle];
}

/** Copies the platform's fixed-point forces into a force slot, in system order. */
KERNEL void copyForces(GLOBAL const mm_long* RESTRICT force, GLOBAL mixed4* RESTRICT slot,
                       GLOBAL const int* RESTRICT atomIndex) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE)
        slot[atomIndex[atom]] =
            make_mixed4(FORCE_SCALE * (mixed)force[atom], FORCE_SCALE * (mixed)force[atom + PADDED_NUM_ATOMS],
                        FORCE_SCALE * (mixed)force[atom + 2 * PADDED_NUM_ATOMS], 0);
}

/** slotOf[particle] = the atom that holds it now. */
KERNEL void findAtoms(GLOBAL const int* RESTRICT atomIndex, GLOBAL int* RESTRICT slotOf) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE)
        slotOf[atomIndex[atom]] = atom;
}

/** v += h M^-1 F for the forces of one slot. */
KERNEL void kick(GLOBAL mixed4* RESTRICT velm, GLOBAL const mixed4* RESTRICT slot, GLOBAL const int* RESTRICT atomIndex,
                 mixed h) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        mixed4 v = velm[atom];
        if (v.w == 0)
            continue;
        applyKick(&v, slot[atomIndex[atom]], h);
        velm[atom] = v;
    }
}

/** q += h v; massless particles never move. */
KERNEL void drift(GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                  GLOBAL const mixed4* RESTRICT velm, mixed h) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        const mixed4 v = velm[atom];
        if (v.w == 0)
            continue;
        mixed4 pos = loadPosition(posq, posqCorrection, atom);
        applyDrift(&pos, v, h);
        storePosition(posq, posqCorrection, atom, pos);
    }
}

/** A constrained drift: its displacement h v, which IntegrationUtilities::applyConstraints() then corrects. */
KERNEL void driftDisplacement(GLOBAL mixed4* RESTRICT posDelta, GLOBAL const mixed4* RESTRICT velm, mixed h) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        const mixed4 v = velm[atom];
        posDelta[atom] = (v.w == 0 ? make_mixed4(0, 0, 0, 0) : make_mixed4(h * v.x, h * v.y, h * v.z, 0));
    }
}

/** A constrained drift: moves by the corrected displacement and sets the velocity to the chord over the drift. */
KERNEL void applyDisplacement(GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                              GLOBAL const mixed4* RESTRICT posDelta, GLOBAL mixed4* RESTRICT velm, mixed inverseTime) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        mixed4 v = velm[atom];
        if (v.w == 0)
            continue;
        const mixed4 before = loadPosition(posq, posqCorrection, atom);
        const mixed4 delta = posDelta[atom];
        mixed4 pos = before;
        pos.x += delta.x;
        pos.y += delta.y;
        pos.z += delta.z;
        storePosition(posq, posqCorrection, atom, pos);
        v.x = (pos.x - before.x) * inverseTime;
        v.y = (pos.y - before.y) * inverseTime;
        v.z = (pos.z - before.z) * inverseTime;
        velm[atom] = v;
    }
}

/**
 * The exact Ornstein-Uhlenbeck flow v = decay v + noise sqrt(kT/m) xi of the thermostated particles (thermalSpeed:
 * sqrt(kT/m), system order; thermostated: 1 or 0, system order).
 */
KERNEL void thermostat(GLOBAL mixed4* RESTRICT velm, GLOBAL const int* RESTRICT atomIndex,
                       GLOBAL const mixed* RESTRICT thermalSpeed, GLOBAL const int* RESTRICT thermostated, mixed decay,
                       mixed noise, mm_ulong stream, unsigned int k0, unsigned int k1,
                       GLOBAL const unsigned int* RESTRICT kn, GLOBAL const mixed* RESTRICT wn,
                       GLOBAL const mixed* RESTRICT fn) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        mixed4 v = velm[atom];
        const int particle = atomIndex[atom];
        if (v.w == 0 || thermostated[particle] == 0)
            continue;
        mixed xi[3];
        counterNormals(stream, (unsigned int)particle, k0, k1, kn, wn, fn, xi);
        applyThermostat(&v, xi, decay, noise * thermalSpeed[particle]);
        velm[atom] = v;
    }
}

/** sum (D x C) += a (D x D) x (D x C), in the order of the CPU engine's propagateSmall. */
DEVICE void addProduct(mixed* sum, GLOBAL const mixed* RESTRICT a, const mixed* x, int D, int C) {
    for (int i = 0; i < D; ++i)
        for (int j = 0; j < D; ++j)
            for (int c = 0; c < C; ++c)
                sum[i * C + c] += a[i * D + j] * x[j * C + c];
}

/**
 * Reads one particle's position, velocity (after the fused kick, if kickStep is not 0) and, when noisy, its two noise
 * vectors into 3-element slices.
 */
DEVICE void readStiffParticle(GLOBAL const real4* RESTRICT posq, GLOBAL const real4* RESTRICT posqCorrection,
                              GLOBAL const mixed4* RESTRICT velm, int atom, int particle,
                              GLOBAL const mixed4* RESTRICT kickForces, mixed kickStep, int noisy, mm_ulong stream,
                              unsigned int k0, unsigned int k1, GLOBAL const unsigned int* RESTRICT kn,
                              GLOBAL const mixed* RESTRICT wn, GLOBAL const mixed* RESTRICT fn, mixed* q, mixed* v,
                              mixed* xi1, mixed* xi2, GLOBAL mixed4* RESTRICT applied, int takeOff) {
    const mixed4 pos = loadPosition(posq, posqCorrection, atom);
    mixed4 vel = velm[atom];
    if (takeOff) {
        // The last step's constraint processing comes off first (the step's first flow; carriedConstraints.cc).
        const mixed4 a = applied[particle];
        vel.x -= a.x;
        vel.y -= a.y;
        vel.z -= a.z;
        applied[particle] = make_mixed4(0, 0, 0, 0);
    }
    q[0] = pos.x;
    q[1] = pos.y;
    q[2] = pos.z;
    v[0] = vel.x;
    v[1] = vel.y;
    v[2] = vel.z;
    if (kickStep != 0) {
        const mixed scale = kickStep * vel.w;
        const mixed4 f = kickForces[particle];
        v[0] += scale * f.x;
        v[1] += scale * f.y;
        v[2] += scale * f.z;
    }
    if (noisy) {
        counterNormals(stream, 2 * (unsigned int)particle, k0, k1, kn, wn, fn, xi1);
        counterNormals(stream, 2 * (unsigned int)particle + 1, k0, k1, kn, wn, fn, xi2);
    }
}

/**
 * Where a stiff flow leaves a particle.  displaced (constraints follow, carriedConstraints.cc): the positions stay, the
 * displacement goes into posDelta and uncorrected, and a carrier (carrierOf[particle] = k >= 0) takes its position
 * solve's inverse mass carrierReals[21 k].
 */
DEVICE void writeStiffParticle(GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                               GLOBAL mixed4* RESTRICT velm, int atom, int particle, const mixed* q, const mixed* v,
                               int displaced, GLOBAL mixed4* RESTRICT posDelta, GLOBAL mixed4* RESTRICT uncorrected,
                               GLOBAL const int* RESTRICT carrierOf, GLOBAL const mixed* RESTRICT carrierReals) {
    mixed4 pos = loadPosition(posq, posqCorrection, atom);
    mixed4 vel = velm[atom];
    if (displaced) {
        const mixed4 delta = make_mixed4(q[0] - pos.x, q[1] - pos.y, q[2] - pos.z, 0);
        posDelta[atom] = delta;
        uncorrected[atom] = delta;
        const int k = carrierOf[particle];
        if (k >= 0)
            vel.w = carrierReals[21 * k];
    } else {
        pos.x = q[0];
        pos.y = q[1];
        pos.z = q[2];
        storePosition(posq, posqCorrection, atom, pos);
    }
    vel.x = v[0];
    vel.y = v[1];
    vel.z = v[2];
    velm[atom] = vel;
}

/**
 * The exact flow of the quadratic stiff potential (StiffModes::Propagator), one component per work-item.
 * components: per component (first particle in particles, number of particles, rows D, columns C); layout: per
 * component 1 if its propagator is in particle space (PropagatorLayout), 0 if in mode space (ModeLayout, with its
 * eigenvectors at eigenvectorOffset and 24 values per particle of scratch at scratchOffset); propagatorOffset: where
 * each component's part of propagator starts.
 */
KERNEL void stiffFlow(int numComponents, GLOBAL const int4* RESTRICT components, GLOBAL const int* RESTRICT layout,
                      GLOBAL const int* RESTRICT particles, GLOBAL const int* RESTRICT slotOf,
                      GLOBAL const mixed* RESTRICT propagator, GLOBAL const int* RESTRICT propagatorOffset,
                      GLOBAL const mixed* RESTRICT eigenvectors, GLOBAL const int* RESTRICT eigenvectorOffset,
                      GLOBAL const mixed* RESTRICT sqrtMass, GLOBAL mixed* RESTRICT scratch,
                      GLOBAL const int* RESTRICT scratchOffset, GLOBAL real4* RESTRICT posq,
                      GLOBAL real4* RESTRICT posqCorrection, GLOBAL mixed4* RESTRICT velm,
                      GLOBAL const mixed4* RESTRICT kickForces, mixed kickStep, int noisy, mm_ulong stream,
                      unsigned int k0, unsigned int k1, GLOBAL const unsigned int* RESTRICT kn,
                      GLOBAL const mixed* RESTRICT wn, GLOBAL const mixed* RESTRICT fn, int displaced,
                      GLOBAL mixed4* RESTRICT posDelta, GLOBAL mixed4* RESTRICT uncorrected,
                      GLOBAL const int* RESTRICT carrierOf, GLOBAL const mixed* RESTRICT carrierReals,
                      GLOBAL mixed4* RESTRICT applied, int takeOff) {
    for (int c = GLOBAL_ID; c < numComponents; c += GLOBAL_SIZE) {
        const int4 comp = components[c];
        const int first = comp.x, numParticles = comp.y, D = comp.z, C = comp.w;
        GLOBAL const mixed* m = propagator + propagatorOffset[c];
        if (layout[c]) {
            // Small: q' = Axx q + Axv v + gx + Nxx xi1, v' = Avx q + Avv v + gv + Nvx xi1 + Nvv xi2 (D x D matrices).
            mixed q[MAX_SMALL_SIZE], v[MAX_SMALL_SIZE], xi1[MAX_SMALL_SIZE], xi2[MAX_SMALL_SIZE];
            mixed newQ[MAX_SMALL_SIZE], newV[MAX_SMALL_SIZE];
            for (int p = 0; p < numParticles; ++p) {
                const int particle = particles[first + p];
                readStiffParticle(posq, posqCorrection, velm, slotOf[particle], particle, kickForces, kickStep, noisy,
                                  stream, k0, k1, kn, wn, fn, q + 3 * p, v + 3 * p, xi1 + 3 * p, xi2 + 3 * p, applied,
                                  takeOff);
            }
            const int DD = D * D, DC = D * C;
            GLOBAL const mixed* gx = m + 4 * DD;
            GLOBAL const mixed* gv = gx + DC;
            GLOBAL const mixed* noiseMatrices = gv + DC;
            for (int k = 0; k < DC; ++k) {
                newQ[k] = gx[k];
                newV[k] = gv[k];
            }
            addProduct(newQ, m, q, D, C);
            addProduct(newQ, m + DD, v, D, C);
            if (noisy)
                addProduct(newQ, noiseMatrices, xi1, D, C);
            addProduct(newV, m + 2 * DD, q, D, C);
            addProduct(newV, m + 3 * DD, v, D, C);
            if (noisy) {
                addProduct(newV, noiseMatrices + DD, xi1, D, C);
                addProduct(newV, noiseMatrices + 2 * DD, xi2, D, C);
            }
            for (int p = 0; p < numParticles; ++p) {
                const int particle = particles[first + p];
                writeStiffParticle(posq, posqCorrection, velm, slotOf[particle], particle, newQ + 3 * p, newV + 3 * p,
                                   displaced, posDelta, uncorrected, carrierOf, carrierReals);
            }
            continue;
        }
        // Large: mass-weighted coordinates into mode space, each mode's 2 x 2 flow and noise, and back.
        GLOBAL const mixed* u = eigenvectors + eigenvectorOffset[c];
        const int width = (noisy ? 4 : 2) * C;
        GLOBAL mixed* particleSpace = scratch + scratchOffset[c];
        GLOBAL mixed* modeSpace = particleSpace + D * width;
        for (int p = 0; p < numParticles; ++p) {
            const int particle = particles[first + p];
            mixed q[3], v[3], xi1[3], xi2[3];
            readStiffParticle(posq, posqCorrection, velm, slotOf[particle], particle, kickForces, kickStep, noisy,
                              stream, k0, k1, kn, wn, fn, q, v, xi1, xi2, applied, takeOff);
            const mixed s = sqrtMass[particle];
            for (int d = 0; d < 3; ++d) {
                GLOBAL mixed* row = particleSpace + (C == 3 ? p * width + d : (3 * p + d) * width);
                row[0] = s * q[d];
                row[C] = s * v[d];
                if (noisy) {
                    row[2 * C] = xi1[d];
                    row[3 * C] = xi2[d];
                }
            }
        }
        // modeSpace = U^T particleSpace.
        for (int k = 0; k < D; ++k) {
            GLOBAL const mixed* column = u + k * D;
            for (int w = 0; w < width; ++w) {
                mixed sum = 0;
                for (int i = 0; i < D; ++i)
                    sum += column[i] * particleSpace[i * width + w];
                modeSpace[k * width + w] = sum;
            }
        }
        const int perMode = noisy ? 7 : 4;
        GLOBAL const mixed* gx = m + perMode * D;
        GLOBAL const mixed* gv = gx + D * C;
        for (int k = 0; k < D; ++k) {
            GLOBAL const mixed* f = m + perMode * k;
            GLOBAL const mixed* in = modeSpace + k * width;
            GLOBAL mixed* out = particleSpace + k * 2 * C;
            for (int col = 0; col < C; ++col) {
                const mixed x = in[col], v = in[C + col];
                mixed newX = f[0] * x + f[1] * v + gx[k * C + col];
                mixed newV = f[2] * x + f[3] * v + gv[k * C + col];
                if (noisy) {
                    newX += f[4] * in[2 * C + col];
                    newV += f[5] * in[2 * C + col] + f[6] * in[3 * C + col];
                }
                out[col] = newX;
                out[C + col] = newV;
            }
        }
        // modeSpace = U particleSpace, four modes at a time as the CPU engine's fromModes.
        const int W = 2 * C;
        for (int i = 0; i < D * W; ++i)
            modeSpace[i] = 0;
        int k = 0;
        for (; k + 4 <= D; k += 4) {
            GLOBAL const mixed* c0 = u + k * D;
            GLOBAL const mixed* c1 = c0 + D;
            GLOBAL const mixed* c2 = c1 + D;
            GLOBAL const mixed* c3 = c2 + D;
            GLOBAL const mixed* mode = particleSpace + k * W;
            for (int i = 0; i < D; ++i)
                for (int w = 0; w < W; ++w)
                    modeSpace[i * W + w] +=
                        c0[i] * mode[w] + c1[i] * mode[W + w] + c2[i] * mode[2 * W + w] + c3[i] * mode[3 * W + w];
        }
        for (; k < D; ++k) {
            GLOBAL const mixed* column = u + k * D;
            GLOBAL const mixed* mode = particleSpace + k * W;
            for (int i = 0; i < D; ++i)
                for (int w = 0; w < W; ++w)
                    modeSpace[i * W + w] += column[i] * mode[w];
        }
        for (int p = 0; p < numParticles; ++p) {
            const int particle = particles[first + p];
            const mixed inverse = 1 / sqrtMass[particle];
            mixed q[3], v[3];
            for (int d = 0; d < 3; ++d) {
                GLOBAL const mixed* row = modeSpace + (C == 3 ? p * 2 * C + d : (3 * p + d) * 2 * C);
                q[d] = inverse * row[0];
                v[d] = inverse * row[C];
            }
            writeStiffParticle(posq, posqCorrection, velm, slotOf[particle], particle, q, v, displaced, posDelta,
                               uncorrected, carrierOf, carrierReals);
        }
    }
}

/**
 * The displacement and velocity change of element (i, col) of a component's D x C block under a force response:
 * U diag(r) modeForce, plus U diag(q) modeChange where processed, summed over the modes in the CPU engine's order.
 */
DEVICE void responseOfElement(int i, int col, int D, int C, GLOBAL const mixed* RESTRICT u,
                              GLOBAL const mixed* RESTRICT r, GLOBAL const mixed* RESTRICT q, int processed,
                              GLOBAL const mixed* RESTRICT modeForce, GLOBAL const mixed* RESTRICT modeChange,
                              mixed* dx, mixed* dv) {
    mixed sx = 0, sv = 0;
    for (int k = 0; k < D; ++k) {
        const mixed projected = u[k * D + i] * modeForce[k * C + col];
        sx += r[2 * k] * projected;
        sv += r[2 * k + 1] * projected;
        if (processed) {
            const mixed projectedChange = u[k * D + i] * modeChange[k * C + col];
            sx += q[2 * k] * projectedChange;
            sv += q[2 * k + 1] * projectedChange;
        }
    }
    *dx = sx;
    *dv = sv;
}

/** carriedConstraints.cc: carrier k readied for a velocity solve (the step's constraint processing first). */
DEVICE void prepareCarrier(int k, int carrierAtom, int numCarried, GLOBAL mixed4* RESTRICT velm,
                           GLOBAL const int* RESTRICT slotOf, GLOBAL const int* RESTRICT motionStart,
                           GLOBAL const int* RESTRICT motionParticle, GLOBAL const mixed* RESTRICT carrierReals,
                           GLOBAL const mixed* RESTRICT motionReals, int numPositionMotions,
                           GLOBAL const mixed4* RESTRICT stepImpulses, GLOBAL mixed4* RESTRICT carrierVelocity,
                           GLOBAL mixed4* RESTRICT applied, int process);

/**
 * A force response of the Filtered and Warped splittings (StiffModes::ForceResponse), one component per work-item,
 * as the CPU engine's ForceResponseTask: x += M^-1/2 U diag(rx) U^T M^-1/2 F and likewise v with rv, for the forces
 * of a slot (system order).  In stiff components (stiff: 1) also the velocity processing, applied to the change of
 * the slot's force over the step: the opening response (closing 0) reads the changes from forceChanges and records
 * the slot's forces in openingForces, the closing one (closing 1) records forces - openingForces in forceChanges and
 * applies that (both system order; the step history).  response and processing hold two values per mode from
 * responseOffset; eigenvectors are column-major D x D from eigenvectorOffset; scratch holds 12 values per particle,
 * from 12 times the component's first index into particles.
 */
KERNEL void forceResponse(int numComponents, GLOBAL const int4* RESTRICT components, GLOBAL const int* RESTRICT stiff,
                          GLOBAL const int* RESTRICT particles, GLOBAL const int* RESTRICT slotOf,
                          GLOBAL const mixed* RESTRICT eigenvectors, GLOBAL const int* RESTRICT eigenvectorOffset,
                          GLOBAL const mixed* RESTRICT sqrtMass, GLOBAL const mixed* RESTRICT response,
                          GLOBAL const mixed* RESTRICT processing, GLOBAL const int* RESTRICT responseOffset,
                          GLOBAL mixed* RESTRICT scratch, GLOBAL const mixed4* RESTRICT forces,
                          GLOBAL mixed4* RESTRICT openingForces, GLOBAL mixed4* RESTRICT forceChanges, int closing,
                          GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                          GLOBAL mixed4* RESTRICT velm, int displaced, GLOBAL mixed4* RESTRICT posDelta,
                          GLOBAL mixed4* RESTRICT uncorrected, int preparing, GLOBAL const int* RESTRICT carrierOf,
                          GLOBAL const mixed* RESTRICT carrierReals, GLOBAL const int* RESTRICT motionStart,
                          GLOBAL const int* RESTRICT motionParticle, GLOBAL const mixed* RESTRICT motionReals,
                          int numPositionMotions, int numCarried, GLOBAL const mixed4* RESTRICT stepImpulses,
                          GLOBAL mixed4* RESTRICT carrierVelocity, GLOBAL mixed4* RESTRICT applied, int process) {
    for (int c = GLOBAL_ID; c < numComponents; c += GLOBAL_SIZE) {
        const int4 comp = components[c];
        const int first = comp.x, numParticles = comp.y, D = comp.z, C = comp.w, size = D * C;
        const int processed = stiff[c];
        GLOBAL const mixed* r = response + responseOffset[c];
        GLOBAL const mixed* q = processing + responseOffset[c];
        GLOBAL const mixed* u = eigenvectors + eigenvectorOffset[c];
        GLOBAL mixed* particleForce = scratch + 12 * first;
        GLOBAL mixed* particleChange = particleForce + size;
        GLOBAL mixed* modeForce = particleChange + size;
        GLOBAL mixed* modeChange = modeForce + size;
        // Element 3 p + d of a D x C block is coordinate d of particle p in both layouts (as in stiffFlow).
        for (int p = 0; p < numParticles; ++p) {
            const int particle = particles[first + p];
            const mixed scale = 1 / sqrtMass[particle];
            const mixed4 slotForce = forces[particle];
            mixed4 change = make_mixed4(0, 0, 0, 0);
            if (processed && closing) {
                change = slotForce - openingForces[particle];
                forceChanges[particle] = change;
            } else if (processed) {
                change = forceChanges[particle];
                openingForces[particle] = slotForce;
            }
            particleForce[3 * p] = scale * slotForce.x;
            particleForce[3 * p + 1] = scale * slotForce.y;
            particleForce[3 * p + 2] = scale * slotForce.z;
            particleChange[3 * p] = scale * change.x;
            particleChange[3 * p + 1] = scale * change.y;
            particleChange[3 * p + 2] = scale * change.z;
        }
        // Into mode coordinates: U^T M^-1/2 F and U^T M^-1/2 (change).
        for (int k = 0; k < D; ++k)
            for (int col = 0; col < C; ++col) {
                mixed sum = 0, sumChange = 0;
                for (int i = 0; i < D; ++i) {
                    sum += u[k * D + i] * particleForce[i * C + col];
                    sumChange += u[k * D + i] * particleChange[i * C + col];
                }
                modeForce[k * C + col] = sum;
                modeChange[k * C + col] = sumChange;
            }
        for (int p = 0; p < numParticles; ++p) {
            const int particle = particles[first + p];
            const int atom = slotOf[particle];
            const mixed scale = 1 / sqrtMass[particle];
            mixed dx[3], dv[3];
            for (int d = 0; d < 3; ++d)
                responseOfElement((3 * p + d) / C, (3 * p + d) % C, D, C, u, r, q, processed, modeForce, modeChange,
                                  &dx[d], &dv[d]);
            if (displaced) {
                // After a displaced stiff flow (writeStiffParticle): the response joins its displacement.
                mixed4 delta = posDelta[atom];
                delta.x += scale * dx[0];
                delta.y += scale * dx[1];
                delta.z += scale * dx[2];
                posDelta[atom] = delta;
                uncorrected[atom] = delta;
            } else {
                mixed4 pos = loadPosition(posq, posqCorrection, atom);
                pos.x += scale * dx[0];
                pos.y += scale * dx[1];
                pos.z += scale * dx[2];
                storePosition(posq, posqCorrection, atom, pos);
            }
            mixed4 vel = velm[atom];
            vel.x += scale * dv[0];
            vel.y += scale * dv[1];
            vel.z += scale * dv[2];
            velm[atom] = vel;
        }
        // A closing response before a device velocity solve: its component's carrier readied for the solve.
        if (preparing)
            for (int p = 0; p < numParticles; ++p) {
                const int particle = particles[first + p];
                const int k = carrierOf[particle];
                if (k >= 0)
                    prepareCarrier(k, slotOf[particle], numCarried, velm, slotOf, motionStart, motionParticle,
                                   carrierReals, motionReals, numPositionMotions, stepImpulses, carrierVelocity,
                                   applied, process);
            }
    }
}

/** Copies the positions and velocities in system order into a snapshot (for a failed checkpoint to put back). */
KERNEL void snapshotState(GLOBAL const real4* RESTRICT posq, GLOBAL const real4* RESTRICT posqCorrection,
                          GLOBAL const mixed4* RESTRICT velm, GLOBAL const int* RESTRICT atomIndex,
                          GLOBAL mixed4* RESTRICT positions, GLOBAL mixed4* RESTRICT velocities) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        const int particle = atomIndex[atom];
        positions[particle] = loadPosition(posq, posqCorrection, atom);
        velocities[particle] = velm[atom];
    }
}

/**
 * A pass of kicks, drifts and thermostats without constraints as one kernel: each particle runs the pass's flows in
 * order (ops: per flow its kind, 0 kick, 1 drift, 2 thermostat, its force slot and its stream offset; opReals: per flow
 * its step, or its decay and noise), with the arithmetic of kick, drift and thermostat above.  The forces of slot
 * bufferSlot (-1: none) are read from the platform's force buffer, not yet copied into their slot.
 */
KERNEL void particlePass(int numOps, GLOBAL const int4* RESTRICT ops, GLOBAL const mixed* RESTRICT opReals,
                         GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                         GLOBAL mixed4* RESTRICT velm, GLOBAL const int* RESTRICT atomIndex,
                         GLOBAL const mixed4* RESTRICT slot0, GLOBAL const mixed4* RESTRICT slot1,
                         GLOBAL const mixed4* RESTRICT slot2, GLOBAL const mixed4* RESTRICT slot3,
                         GLOBAL const mixed* RESTRICT thermalSpeed, GLOBAL const int* RESTRICT thermostated,
                         GLOBAL const mm_long* RESTRICT forceBuffer, int bufferSlot, mm_ulong stream, unsigned int k0,
                         unsigned int k1, GLOBAL const unsigned int* RESTRICT kn, GLOBAL const mixed* RESTRICT wn,
                         GLOBAL const mixed* RESTRICT fn) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        mixed4 v = velm[atom];
        if (v.w == 0)
            continue;
        const int particle = atomIndex[atom];
        mixed4 pos = loadPosition(posq, posqCorrection, atom);
        bool moved = false;
        for (int k = 0; k < numOps; ++k) {
            const int4 op = ops[k];
            if (op.x == 0) {
                GLOBAL const mixed4* slot = op.y == 0 ? slot0 : op.y == 1 ? slot1 : op.y == 2 ? slot2 : slot3;
                applyKick(&v, slotForce(slot, forceBuffer, op.y == bufferSlot, particle, atom), opReals[2 * k]);
            } else if (op.x == 1) {
                applyDrift(&pos, v, opReals[2 * k]);
                moved = true;
            } else if (thermostated[particle] != 0) {
                mixed xi[3];
                counterNormals(stream + (mm_ulong)op.z, (unsigned int)particle, k0, k1, kn, wn, fn, xi);
                applyThermostat(&v, xi, opReals[2 * k], opReals[2 * k + 1] * thermalSpeed[particle]);
            }
        }
        if (moved)
            storePosition(posq, posqCorrection, atom, pos);
        velm[atom] = v;
    }
}

/** A Metropolis proposal starts: the positions and velocities kept (atom order, within the step). */
KERNEL void saveProposalStart(GLOBAL const real4* RESTRICT posq, GLOBAL const real4* RESTRICT posqCorrection,
                              GLOBAL const mixed4* RESTRICT velm, GLOBAL mixed4* RESTRICT startPositions,
                              GLOBAL mixed4* RESTRICT startVelocities) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        startPositions[atom] = loadPosition(posq, posqCorrection, atom);
        startVelocities[atom] = velm[atom];
    }
}

/** A rejected proposal: the start's positions back, its velocities reversed. */
KERNEL void rejectProposal(GLOBAL real4* RESTRICT posq, GLOBAL real4* RESTRICT posqCorrection,
                           GLOBAL mixed4* RESTRICT velm, GLOBAL const mixed4* RESTRICT startPositions,
                           GLOBAL const mixed4* RESTRICT startVelocities) {
    for (int atom = GLOBAL_ID; atom < NUM_ATOMS; atom += GLOBAL_SIZE) {
        storePosition(posq, posqCorrection, atom, startPositions[atom]);
        const mixed4 v = startVelocities[atom];
        velm[atom] = make_mixed4(-v.x, -v.y, -v.z, v.w);
    }
}

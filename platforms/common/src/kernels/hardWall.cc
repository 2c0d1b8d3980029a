/**
 * The SIM's hard wall on the device (DeviceHardWall), the arithmetic of the host's HardWall, one work-item per stiff
 * pair.  pairs: (Drude particle, parent, 1 if the parent stays where it is, 0), system order; pairMasses: (Drude
 * mass, parent mass, 0, 0); axes: per pair the axis parent to Drude of a pair put back, w = 1 (0: not put back).  A
 * pair past twice the wall stays as it is and sets failure[0] to 2 + its index, read by the host where the next step
 * starts.
 */

KERNEL void hardWallPositions(int numPairs, GLOBAL const int4* RESTRICT pairs, GLOBAL const mixed4* RESTRICT pairMasses,
                              GLOBAL const int* RESTRICT slotOf, GLOBAL real4* RESTRICT posq,
                              GLOBAL real4* RESTRICT posqCorrection, GLOBAL mixed4* RESTRICT axes,
                              GLOBAL int* RESTRICT failure, mixed wall, mixed dt, mixed kT) {
    for (int i = GLOBAL_ID; i < numPairs; i += GLOBAL_SIZE) {
        const int4 pair = pairs[i];
        const int drudeAtom = slotOf[pair.x], parentAtom = slotOf[pair.y];
        mixed4 drude = loadPosition(posq, posqCorrection, drudeAtom);
        mixed4 parent = loadPosition(posq, posqCorrection, parentAtom);
        const mixed dx = drude.x - parent.x, dy = drude.y - parent.y, dz = drude.z - parent.z;
        const mixed r = SQRT(dx * dx + dy * dy + dz * dz);
        axes[i] = make_mixed4(0, 0, 0, 0);
        if (!(r <= 2 * wall)) {
            failure[0] = 2 + i;
            continue;
        }
        if (r <= wall)
            continue;
        const mixed ax = dx / r, ay = dy / r, az = dz / r;
        const mixed4 masses = pairMasses[i];
        // Back inside by the overshoot and by what the thermal speed covers in the step (HardWall::movePositions).
        const mixed inward = (r - wall) + dt * SQRT(kT / masses.x);
        if (pair.z) {
            drude.x -= ax * inward;
            drude.y -= ay * inward;
            drude.z -= az * inward;
        } else {
            const mixed inverseTotal = 1 / (masses.x + masses.y);
            const mixed drudeShare = inward * masses.y * inverseTotal, parentShare = inward * masses.x * inverseTotal;
            drude.x -= ax * drudeShare;
            drude.y -= ay * drudeShare;
            drude.z -= az * drudeShare;
            parent.x += ax * parentShare;
            parent.y += ay * parentShare;
            parent.z += az * parentShare;
            storePosition(posq, posqCorrection, parentAtom, parent);
        }
        storePosition(posq, posqCorrection, drudeAtom, drude);
        axes[i] = make_mixed4(ax, ay, az, 1);
    }
}

/** After the closing kick: the radial velocity of each pair put back set to the thermal speed inward. */
KERNEL void hardWallSpeeds(int numPairs, GLOBAL const int4* RESTRICT pairs, GLOBAL const mixed4* RESTRICT pairMasses,
                           GLOBAL const int* RESTRICT slotOf, GLOBAL mixed4* RESTRICT velm,
                           GLOBAL const mixed4* RESTRICT axes, mixed kT) {
    for (int i = GLOBAL_ID; i < numPairs; i += GLOBAL_SIZE) {
        const mixed4 axis = axes[i];
        if (axis.w == 0)
            continue;
        const int4 pair = pairs[i];
        const int drudeAtom = slotOf[pair.x], parentAtom = slotOf[pair.y];
        const mixed4 masses = pairMasses[i];
        const mixed speed = SQRT(kT / masses.x);
        mixed4 v1 = velm[drudeAtom];
        mixed4 v2 = velm[parentAtom];
        const mixed radial1 = v1.x * axis.x + v1.y * axis.y + v1.z * axis.z;
        const mixed radial2 = v2.x * axis.x + v2.y * axis.y + v2.z * axis.z;
        if (pair.z) {
            const mixed change = radial2 - speed - radial1;
            v1.x += axis.x * change;
            v1.y += axis.y * change;
            v1.z += axis.z * change;
            velm[drudeAtom] = v1;
            continue;
        }
        const mixed inverseTotal = 1 / (masses.x + masses.y);
        const mixed centre = (masses.x * radial1 + masses.y * radial2) * inverseTotal;
        const mixed change1 = centre - speed * masses.y * inverseTotal - radial1;
        const mixed change2 = centre + speed * masses.x * inverseTotal - radial2;
        v1.x += axis.x * change1;
        v1.y += axis.y * change1;
        v1.z += axis.z * change1;
        v2.x += axis.x * change2;
        v2.y += axis.y * change2;
        v2.z += axis.z * change2;
        velm[drudeAtom] = v1;
        velm[parentAtom] = v2;
    }
}

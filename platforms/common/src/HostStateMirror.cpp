#include "HostStateMirror.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

HostStateMirror::HostStateMirror(ComputeContext& cc, int numParticles)
    : positions(numParticles), velocities(numParticles), cc(cc), doubles(cc.getUseDoublePrecision()),
      mixed(cc.getUseMixedPrecision()) {
    const size_t padded = cc.getPaddedNumAtoms();
    if (doubles) {
        posqDouble.resize(padded);
        velmDouble.resize(padded);
    } else {
        posqFloat.resize(padded);
        if (mixed) {
            correctionFloat.resize(padded);
            velmDouble.resize(padded);
        } else {
            velmFloat.resize(padded);
        }
    }
}

void HostStateMirror::downloadPositions() {
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    if (doubles) {
        cc.getPosq().download(posqDouble);
        for (int atom = 0; atom < numAtoms; ++atom)
            positions[order[atom]] = Vec3(posqDouble[atom].x, posqDouble[atom].y, posqDouble[atom].z);
        return;
    }
    cc.getPosq().download(posqFloat);
    if (mixed)
        cc.getPosqCorrection().download(correctionFloat);
    for (int atom = 0; atom < numAtoms; ++atom) {
        const mm_float4& p = posqFloat[atom];
        Vec3 position(p.x, p.y, p.z);
        if (mixed)
            position += Vec3(correctionFloat[atom].x, correctionFloat[atom].y, correctionFloat[atom].z);
        positions[order[atom]] = position;
    }
}

void HostStateMirror::downloadVelocities() {
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    if (doubles || mixed) {
        cc.getVelm().download(velmDouble);
        for (int atom = 0; atom < numAtoms; ++atom)
            velocities[order[atom]] = Vec3(velmDouble[atom].x, velmDouble[atom].y, velmDouble[atom].z);
    } else {
        cc.getVelm().download(velmFloat);
        for (int atom = 0; atom < numAtoms; ++atom)
            velocities[order[atom]] = Vec3(velmFloat[atom].x, velmFloat[atom].y, velmFloat[atom].z);
    }
}

void HostStateMirror::uploadPositions() {
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    if (doubles) {
        for (int atom = 0; atom < numAtoms; ++atom) {
            const Vec3& q = positions[order[atom]];
            posqDouble[atom] = mm_double4(q[0], q[1], q[2], posqDouble[atom].w);
        }
        cc.getPosq().upload(posqDouble);
        return;
    }
    for (int atom = 0; atom < numAtoms; ++atom) {
        const Vec3& q = positions[order[atom]];
        const mm_float4 rounded((float)q[0], (float)q[1], (float)q[2], posqFloat[atom].w);
        posqFloat[atom] = rounded;
        if (mixed)
            correctionFloat[atom] =
                mm_float4((float)(q[0] - rounded.x), (float)(q[1] - rounded.y), (float)(q[2] - rounded.z), 0);
    }
    cc.getPosq().upload(posqFloat);
    if (mixed)
        cc.getPosqCorrection().upload(correctionFloat);
}

void HostStateMirror::uploadVelocities() {
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    if (doubles || mixed) {
        for (int atom = 0; atom < numAtoms; ++atom) {
            const Vec3& v = velocities[order[atom]];
            velmDouble[atom] = mm_double4(v[0], v[1], v[2], velmDouble[atom].w);
        }
        cc.getVelm().upload(velmDouble);
    } else {
        for (int atom = 0; atom < numAtoms; ++atom) {
            const Vec3& v = velocities[order[atom]];
            velmFloat[atom] = mm_float4((float)v[0], (float)v[1], (float)v[2], velmFloat[atom].w);
        }
        cc.getVelm().upload(velmFloat);
    }
}

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

namespace {

/** One device array and its host buffer. */
struct Transfer {
    OpenMM::ArrayInterface* array;
    void* host;
};

/** At most four arrays per call (an extra one, posq, its correction, velm): no allocation per step. */
struct Transfers {
    Transfer items[4];
    int count = 0;
    void add(OpenMM::ArrayInterface* array, void* host) { items[count++] = {array, host}; }
};

/** Every copy but the last without waiting; the last waits, and with the queue in order so do the others. */
void downloadAll(const Transfers& transfers) {
    for (int i = 0; i < transfers.count; ++i)
        transfers.items[i].array->download(transfers.items[i].host, i + 1 == transfers.count);
}

void uploadAll(const Transfers& transfers) {
    for (int i = 0; i < transfers.count; ++i)
        transfers.items[i].array->upload(transfers.items[i].host, i + 1 == transfers.count);
}

} // namespace

void HostStateMirror::download(bool withPositions, bool withVelocities, const ArrayInterface* extra,
                               void* extraTarget) {
    Transfers transfers;
    if (extra != nullptr)
        transfers.add(const_cast<ArrayInterface*>(extra), extraTarget);
    if (withPositions) {
        transfers.add(&cc.getPosq(), doubles ? (void*)posqDouble.data() : (void*)posqFloat.data());
        if (mixed)
            transfers.add(&cc.getPosqCorrection(), correctionFloat.data());
    }
    if (withVelocities)
        transfers.add(&cc.getVelm(), doubles || mixed ? (void*)velmDouble.data() : (void*)velmFloat.data());
    downloadAll(transfers);
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    if (withPositions)
        for (int atom = 0; atom < numAtoms; ++atom) {
            Vec3 position;
            if (doubles) {
                position = Vec3(posqDouble[atom].x, posqDouble[atom].y, posqDouble[atom].z);
            } else {
                position = Vec3(posqFloat[atom].x, posqFloat[atom].y, posqFloat[atom].z);
                if (mixed)
                    position += Vec3(correctionFloat[atom].x, correctionFloat[atom].y, correctionFloat[atom].z);
            }
            positions[order[atom]] = position;
        }
    if (withVelocities)
        for (int atom = 0; atom < numAtoms; ++atom)
            velocities[order[atom]] = doubles || mixed
                                          ? Vec3(velmDouble[atom].x, velmDouble[atom].y, velmDouble[atom].z)
                                          : Vec3(velmFloat[atom].x, velmFloat[atom].y, velmFloat[atom].z);
}

void HostStateMirror::upload(bool withPositions, bool withVelocities) {
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    Transfers transfers;
    if (withPositions) {
        for (int atom = 0; atom < numAtoms; ++atom) {
            const Vec3& q = positions[order[atom]];
            if (doubles) {
                posqDouble[atom] = mm_double4(q[0], q[1], q[2], posqDouble[atom].w);
                continue;
            }
            const mm_float4 rounded((float)q[0], (float)q[1], (float)q[2], posqFloat[atom].w);
            posqFloat[atom] = rounded;
            if (mixed)
                correctionFloat[atom] =
                    mm_float4((float)(q[0] - rounded.x), (float)(q[1] - rounded.y), (float)(q[2] - rounded.z), 0);
        }
        transfers.add(&cc.getPosq(), doubles ? (void*)posqDouble.data() : (void*)posqFloat.data());
        if (mixed)
            transfers.add(&cc.getPosqCorrection(), correctionFloat.data());
    }
    if (withVelocities) {
        for (int atom = 0; atom < numAtoms; ++atom) {
            const Vec3& v = velocities[order[atom]];
            if (doubles || mixed)
                velmDouble[atom] = mm_double4(v[0], v[1], v[2], velmDouble[atom].w);
            else
                velmFloat[atom] = mm_float4((float)v[0], (float)v[1], (float)v[2], velmFloat[atom].w);
        }
        transfers.add(&cc.getVelm(), doubles || mixed ? (void*)velmDouble.data() : (void*)velmFloat.data());
    }
    uploadAll(transfers);
}

#include "HostFrozenStage.h"
#include "openmm/OpenMMException.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

HostFrozenStage::HostFrozenStage(ComputeContext& cc, const System& system)
    : cc(cc), doubles(cc.getUseDoublePrecision()), mixed(cc.getUseMixedPrecision()),
      inverseMasses(system.getNumParticles(), 0.0), positions(system.getNumParticles()),
      velocities(system.getNumParticles()), forceValues(system.getNumParticles()) {
    for (int i = 0; i < system.getNumParticles(); ++i)
        if (system.getParticleMass(i) != 0.0)
            inverseMasses[i] = 1.0 / system.getParticleMass(i);
    const size_t padded = cc.getPaddedNumAtoms();
    if (doubles) {
        posqDouble.resize(padded);
        velmDouble.resize(padded);
        forcesDouble.resize(system.getNumParticles());
    } else {
        posqFloat.resize(padded);
        if (mixed) {
            correctionFloat.resize(padded);
            velmDouble.resize(padded);
            forcesDouble.resize(system.getNumParticles());
        } else {
            velmFloat.resize(padded);
            forcesFloat.resize(system.getNumParticles());
        }
    }
}

void HostFrozenStage::setDistances(std::shared_ptr<FrozenDistances> newDistances) {
    distances = std::move(newDistances);
}

void HostFrozenStage::setStiffModes(std::shared_ptr<const StiffModes> newModes) {
    if (newModes != modes)
        modeTask = newModes ? std::make_unique<FrozenFlowTask>(*newModes) : nullptr;
    modes = std::move(newModes);
}

void HostFrozenStage::forgetFactorizations() {
    if (distances)
        distances->forgetFactorizations();
}

void HostFrozenStage::run(const SubFlow& flow, const ComputeArray* forces, double tolerance, bool projectOthers) {
    const bool onDistances = flow.frozen == SubFlow::FrozenSet::Distances;
    if (onDistances ? !distances : !modes)
        throw OpenMMException("HostFrozenStage: a frozen flow on " + std::string(onDistances
                                                                                     ? "distances needs setDistances()"
                                                                                     : "stiff modes needs "
                                                                                       "setStiffModes()"));
    const bool drift = flow.kind == SubFlow::FrozenDrift;
    download(drift ? nullptr : forces);
    if (onDistances) {
        if (drift)
            distances->drift(positions, velocities, inverseMasses, flow.h, tolerance, projectOthers, loop);
        else
            distances->kick(positions, velocities, forceValues, inverseMasses, flow.h, tolerance, projectOthers, loop);
    } else {
        modeTask->h = flow.h;
        modeTask->source = drift ? velocities.data() : forceValues.data();
        modeTask->target = drift ? positions.data() : velocities.data();
        modeTask->sourceIsForce = !drift;
        loop.run(*modeTask, modes->getNumComponents());
    }
    upload(drift);
}

void HostFrozenStage::download(const ComputeArray* forces) {
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    if (doubles) {
        cc.getPosq().download(posqDouble);
        for (int atom = 0; atom < numAtoms; ++atom)
            positions[order[atom]] = Vec3(posqDouble[atom].x, posqDouble[atom].y, posqDouble[atom].z);
    } else {
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
    if (doubles || mixed) {
        cc.getVelm().download(velmDouble);
        for (int atom = 0; atom < numAtoms; ++atom)
            velocities[order[atom]] = Vec3(velmDouble[atom].x, velmDouble[atom].y, velmDouble[atom].z);
    } else {
        cc.getVelm().download(velmFloat);
        for (int atom = 0; atom < numAtoms; ++atom)
            velocities[order[atom]] = Vec3(velmFloat[atom].x, velmFloat[atom].y, velmFloat[atom].z);
    }
    if (forces == nullptr)
        return;
    // Force slots are already in the System's order.
    if (doubles || mixed) {
        forces->download(forcesDouble);
        for (size_t i = 0; i < forceValues.size(); ++i)
            forceValues[i] = Vec3(forcesDouble[i].x, forcesDouble[i].y, forcesDouble[i].z);
    } else {
        forces->download(forcesFloat);
        for (size_t i = 0; i < forceValues.size(); ++i)
            forceValues[i] = Vec3(forcesFloat[i].x, forcesFloat[i].y, forcesFloat[i].z);
    }
}

void HostFrozenStage::upload(bool positionsMoved) {
    // The fourth components (charges, inverse masses) go back as they came.
    const vector<int>& order = cc.getAtomIndex();
    const int numAtoms = cc.getNumAtoms();
    if (positionsMoved) {
        if (doubles) {
            for (int atom = 0; atom < numAtoms; ++atom) {
                const Vec3& q = positions[order[atom]];
                posqDouble[atom] = mm_double4(q[0], q[1], q[2], posqDouble[atom].w);
            }
            cc.getPosq().upload(posqDouble);
        } else {
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
    }
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

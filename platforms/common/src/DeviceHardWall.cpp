#include "DeviceHardWall.h"
#include "DeviceUploads.h"
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

DeviceHardWall::DeviceHardWall(ComputeContext& cc, ComputeProgram& program, ComputeArray& slotOf,
                               DeviceFailureFlag& failure)
    : cc(cc), failure(failure) {
    pairs.initialize<mm_int4>(cc, 1, "flavorWallPairs");
    initializeMixed4(cc, pairMasses, 1, "flavorWallMasses");
    initializeMixed4(cc, axes, 1, "flavorWallAxes");
    positionsKernel = program->createKernel("hardWallPositions");
    speedsKernel = program->createKernel("hardWallSpeeds");
    positionsKernel->addArg(0);
    positionsKernel->addArg(pairs);
    positionsKernel->addArg(pairMasses);
    positionsKernel->addArg(slotOf);
    positionsKernel->addArg(cc.getPosq());
    positionsKernel->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
    positionsKernel->addArg(axes);
    positionsKernel->addArg(failure.getArray());
    for (int k = 0; k < 3; ++k)
        addMixedArg(cc, positionsKernel, 0.0);
    speedsKernel->addArg(0);
    speedsKernel->addArg(pairs);
    speedsKernel->addArg(pairMasses);
    speedsKernel->addArg(slotOf);
    speedsKernel->addArg(cc.getVelm());
    speedsKernel->addArg(axes);
    addMixedArg(cc, speedsKernel, 0.0);
}

void DeviceHardWall::setPairs(const HardWall& wall, const ParticleTable& particles) {
    hostPairs = wall.getPairs();
    const int numPairs = (int)hostPairs.size();
    vector<mm_int4> table;
    vector<double> masses;
    for (const HardWall::Pair& pair : hostPairs) {
        table.emplace_back(pair.drude, pair.parent, pair.parentFixed ? 1 : 0, 0);
        masses.insert(masses.end(), {particles.masses[pair.drude], particles.masses[pair.parent], 0.0, 0.0});
    }
    if (numPairs == 0)
        return;
    pairs.resize(numPairs);
    pairs.upload(table);
    // As four mixed per pair: uploadMixed sizes a scalar array, so the mixed4 arrays are made again at this size.
    pairMasses.resize(numPairs);
    axes.resize(numPairs);
    cc.clearBuffer(axes);
    const bool doubles = mixedIsDouble(cc);
    if (doubles) {
        pairMasses.upload(masses.data());
    } else {
        vector<float> single(masses.begin(), masses.end());
        pairMasses.upload(single.data());
    }
    for (ComputeKernel* kernel : {&positionsKernel, &speedsKernel}) {
        (*kernel)->setArg(0, numPairs);
        (*kernel)->setArg(1, pairs);
        (*kernel)->setArg(2, pairMasses);
    }
    positionsKernel->setArg(6, axes);
    speedsKernel->setArg(5, axes);
}

void DeviceHardWall::movePositions(double wall, double dt, double kT) {
    if (hostPairs.empty())
        return;
    setMixedArg(cc, positionsKernel, 8, wall);
    setMixedArg(cc, positionsKernel, 9, dt);
    setMixedArg(cc, positionsKernel, 10, kT);
    positionsKernel->execute((int)hostPairs.size());
    failure.markUsed();
    lastWall = wall;
}

void DeviceHardWall::setSpeeds(double kT) {
    if (hostPairs.empty())
        return;
    setMixedArg(cc, speedsKernel, 6, kT);
    speedsKernel->execute((int)hostPairs.size());
}

std::string DeviceHardWall::failureMessage(int code) const {
    const HardWall::Pair& pair = hostPairs.at(code - FirstFailureCode);
    return HardWall::tooFarMessage(pair.drude, pair.parent, -1.0, lastWall);
}

#ifndef OPENMM_FLAVORS_DEVICE_HARD_WALL_H_
#define OPENMM_FLAVORS_DEVICE_HARD_WALL_H_

#include "DeviceFailureFlag.h"
#include "HardWall.h"
#include "ParticleTable.h"
#include "openmm/common/ComputeArray.h"
#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeKernel.h"
#include "openmm/common/ComputeProgram.h"
#include <string>

namespace FlavorPlugin {

/**
 * The SIM's hard wall (HardWall, HardWallSpeed sub-flows) on the device, one work-item per stiff pair
 * (kernels/hardWall.cc), over the pairs the host's HardWall finds; the host's HardWall, which Reference and CPU run,
 * is the oracle its tests compare with.  A pair past twice the wall sets the step's failure flag: the exception comes
 * where the next step starts, and the other pairs have been put back.
 */
class DeviceHardWall {
public:
    DeviceHardWall(OpenMM::ComputeContext& cc, OpenMM::ComputeProgram& program, OpenMM::ComputeArray& slotOf,
                   DeviceFailureFlag& failure);
    /** The pairs of a HardWall whose stiff modes were just set; their masses from particles. */
    void setPairs(const HardWall& wall, const ParticleTable& particles);
    /** HardWall: puts back the pairs farther apart than wall (nm), the overshoot reflected for dt at kT. */
    void movePositions(double wall, double dt, double kT);
    /** HardWallSpeed: the pairs the last movePositions() put back leave the wall inward at the thermal speed of kT. */
    void setSpeeds(double kT);
    /** The message for a failure code this stage set (at least FirstFailureCode). */
    std::string failureMessage(int code) const;
    static const int FirstFailureCode = 2;

private:
    OpenMM::ComputeContext& cc;
    DeviceFailureFlag& failure;
    OpenMM::ComputeArray pairs, pairMasses, axes;
    OpenMM::ComputeKernel positionsKernel, speedsKernel;
    std::vector<HardWall::Pair> hostPairs;
    double lastWall = 0.0;
};

} // namespace FlavorPlugin

#endif

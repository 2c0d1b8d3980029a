#ifndef OPENMM_FLAVORS_CONTEXT_ROLLBACK_H_
#define OPENMM_FLAVORS_CONTEXT_ROLLBACK_H_

#include "internal/windowsExportFlavors.h"
#include "openmm/Vec3.h"
#include <map>
#include <string>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/**
 * A copy of the Context's positions, velocities, periodic box, time, step count and parameters, for a failed
 * loadCheckpoint() to put back: OpenMM reads its own part of a checkpoint, and overwrites the Context with it, before
 * the integrator reads its part.  On Reference and CPU it copies ReferencePlatform::PlatformData; on other platforms
 * (OpenCL) it goes through ContextImpl's getters and setters.
 */
class OPENMM_EXPORT_FLAVORS ContextRollback {
public:
    /** Remembers the Context's state (no allocation after the first call), its parameters too if withParameters. */
    void save(OpenMM::ContextImpl& context, bool withParameters);
    /**
     * Remembers all but the particles' positions and velocities, which the caller keeps (a GPU platform: a copy on the
     * device, which costs no transfer) and puts into savedPositions() and savedVelocities() before restore().
     */
    void saveAllButParticles(OpenMM::ContextImpl& context, bool withParameters);
    std::vector<OpenMM::Vec3>& savedPositions() { return positions; }
    std::vector<OpenMM::Vec3>& savedVelocities() { return velocities; }
    /** Puts the remembered state back (nothing if none was saved). */
    void restore(OpenMM::ContextImpl& context);

private:
    bool valid = false;
    std::vector<OpenMM::Vec3> positions, velocities;
    OpenMM::Vec3 boxSize, boxVectors[3];
    double time = 0.0;
    long long stepCount = 0;
    std::map<std::string, double> parameters;
};

} // namespace FlavorPlugin

#endif

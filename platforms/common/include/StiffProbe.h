#ifndef OPENMM_FLAVORS_STIFF_PROBE_H_
#define OPENMM_FLAVORS_STIFF_PROBE_H_

#include "StiffModes.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/Vec3.h"
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/** The stiffness matrix K (nonzero blocks, i <= j) and constant force b of a quadratic stiff potential. */
struct ProbedStiffness {
    std::vector<StiffnessBlock> blocks;
    std::vector<OpenMM::Vec3> constantForce;
    /** The relative deviation from linearity measured at a random displacement. */
    double linearityDeviation;
};

/**
 * Measures K and b of the force groups stiffGroups.  First, with three force evaluations at multiples of one random
 * displacement of every particle with mass, it checks that the forces are linear in the positions (second and third
 * differences vanish) and throws an OpenMMException reporting the measured deviation if they are not.  Then it
 * measures K by central differences of the forces around the current positions and checks at another random
 * displacement that the forces really are -K q + b.  Particles linked by the bonded stiff forces
 * (ForceImpl::getBondedParticles) are probed together, one particle of every linked group at a time, so the cost
 * grows with the largest group, not with the number of groups; if that misses a coupling, every particle is probed
 * on its own.  Massless particles are fixed: they are never displaced and the forces on them are ignored.  Throws an
 * OpenMMException if the forces are not linear in the positions or K is not symmetric.  The Context's positions are
 * left as they were.
 */
OPENMM_EXPORT_FLAVORS ProbedStiffness probeStiffness(OpenMM::ContextImpl& context, int stiffGroups,
                                                     const std::vector<double>& masses);

} // namespace FlavorPlugin

#endif

#include "internal/StiffGroupChecks.h"
#include "openmm/Force.h"
#include "openmm/OpenMMException.h"
#include "openmm/System.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/internal/ForceImpl.h"
#include <string>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

vector<bool> FlavorPlugin::bondedStiffParticles(ContextImpl& context, int stiffGroups) {
    vector<bool> stiff(context.getSystem().getNumParticles(), false);
    for (ForceImpl* impl : context.getForceImpls())
        if ((stiffGroups & (1 << impl->getOwner().getForceGroup())) != 0)
            for (const std::pair<int, int>& bond : impl->getBondedParticles())
                stiff[bond.first] = stiff[bond.second] = true;
    return stiff;
}

void FlavorPlugin::rejectConstrainedStiffParticles(const ContextImpl& context, const vector<bool>& stiff,
                                                   const std::string& owner, const std::string& alternative) {
    const System& system = context.getSystem();
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        if (stiff[p1] || stiff[p2])
            throw OpenMMException(owner + ": constraint " + std::to_string(c) + " between particles " +
                                  std::to_string(p1) + " and " + std::to_string(p2) + " touches particle " +
                                  std::to_string(stiff[p1] ? p1 : p2) +
                                  " of a stiff component; the exact stiff flow cannot hold constraints.  Remove the "
                                  "constraint or " +
                                  alternative);
    }
}

#include "internal/StiffGroupChecks.h"
#include "internal/UnionFind.h"
#include "openmm/CMAPTorsionForce.h"
#include "openmm/CustomAngleForce.h"
#include "openmm/CustomGBForce.h"
#include "openmm/CustomHbondForce.h"
#include "openmm/CustomManyParticleForce.h"
#include "openmm/CustomTorsionForce.h"
#include "openmm/Force.h"
#include "openmm/GBSAOBCForce.h"
#include "openmm/NonbondedForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/PeriodicTorsionForce.h"
#include "openmm/RBTorsionForce.h"
#include "openmm/System.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/internal/ForceImpl.h"
#include <map>
#include <string>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

vector<int> FlavorPlugin::bondedStiffComponents(ContextImpl& context, int stiffGroups) {
    const int numParticles = context.getSystem().getNumParticles();
    vector<int> parent(numParticles);
    vector<bool> stiff(numParticles, false);
    for (int i = 0; i < numParticles; ++i)
        parent[i] = i;
    for (ForceImpl* impl : context.getForceImpls())
        if ((stiffGroups & (1 << impl->getOwner().getForceGroup())) != 0)
            for (const std::pair<int, int>& bond : impl->getBondedParticles()) {
                stiff[bond.first] = stiff[bond.second] = true;
                parent[findRoot(parent, bond.first)] = findRoot(parent, bond.second);
            }
    vector<int> componentOf(numParticles, -1), lowest(numParticles, -1);
    for (int i = 0; i < numParticles; ++i)
        if (stiff[i]) {
            const int root = findRoot(parent, i);
            if (lowest[root] < 0)
                lowest[root] = i;
            componentOf[i] = lowest[root];
        }
    return componentOf;
}

void FlavorPlugin::rejectConstraintsInsideStiffComponents(const ContextImpl& context, const vector<int>& componentOf) {
    const System& system = context.getSystem();
    // For each component, its constrained particle so far (-1: none yet).
    std::map<int, int> constrainedParticle;
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        const string constraint = "constraint " + std::to_string(c) + " between particles " + std::to_string(p1) +
                                  " and " + std::to_string(p2);
        if (componentOf[p1] >= 0 && componentOf[p1] == componentOf[p2])
            throw OpenMMException("StochasticImpulseIntegrator: " + constraint +
                                  " joins two particles of one stiff component (the component of particle " +
                                  std::to_string(componentOf[p1]) +
                                  "); the exact stiff flow cannot hold a constraint inside a component.  Constraints "
                                  "are allowed only between a stiff component and particles outside it: remove the "
                                  "constraint or the stiff force between these particles");
        for (int p : {p1, p2}) {
            if (componentOf[p] < 0)
                continue;
            auto found = constrainedParticle.find(componentOf[p]);
            if (found == constrainedParticle.end())
                constrainedParticle[componentOf[p]] = p;
            else if (found->second != p)
                throw OpenMMException(
                    "StochasticImpulseIntegrator: " + constraint + " touches particle " + std::to_string(p) +
                    ", and particle " + std::to_string(found->second) +
                    " of the same stiff component is constrained too; at most one particle of each stiff component "
                    "may be constrained (the component's flow carries its constraint impulses to the others, e.g. to "
                    "a Drude particle from its core)");
        }
    }
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

string FlavorPlugin::describeForce(const System& system, int f) {
    const Force& force = system.getForce(f);
    return "force " + std::to_string(f) + " (" + force.getName() + ", force group " +
           std::to_string(force.getForceGroup()) + ")";
}

string FlavorPlugin::describeUnfreezableForces(const vector<string>& forces) {
    string list;
    for (const string& force : forces)
        list += (list.empty() ? "" : ", ") + force;
    return "FlavorIntegrator: the artificial averaging freezes the stiff degrees of freedom, but the frozen "
           "coordinates of " +
           list +
           " cannot be determined: the stiff force groups are not quadratic, and only HarmonicBondForce, "
           "CustomBondForce and HarmonicAngleForce have known frozen distances.  Declare its frozen distances with "
           "FlavorIntegrator::addFrozenDistance(), move it to a soft force group, or use the Nonintrusive averaging";
}

void FlavorPlugin::rejectUnfreezableStiffForces(const System& system, int stiffGroups, bool frozenDistancesDeclared) {
    if (frozenDistancesDeclared)
        return;
    vector<string> unfreezable;
    for (int f = 0; f < system.getNumForces(); ++f) {
        const Force& force = system.getForce(f);
        if ((stiffGroups & (1 << force.getForceGroup())) == 0)
            continue;
        if (dynamic_cast<const NonbondedForce*>(&force) || dynamic_cast<const PeriodicTorsionForce*>(&force) ||
            dynamic_cast<const RBTorsionForce*>(&force) || dynamic_cast<const CMAPTorsionForce*>(&force) ||
            dynamic_cast<const CustomTorsionForce*>(&force) || dynamic_cast<const CustomAngleForce*>(&force) ||
            dynamic_cast<const GBSAOBCForce*>(&force) || dynamic_cast<const CustomGBForce*>(&force) ||
            dynamic_cast<const CustomHbondForce*>(&force) || dynamic_cast<const CustomManyParticleForce*>(&force))
            unfreezable.push_back(describeForce(system, f));
    }
    if (!unfreezable.empty())
        throw OpenMMException(describeUnfreezableForces(unfreezable));
}

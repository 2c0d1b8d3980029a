#ifndef OPENMM_FLAVORS_FORCE_CACHE_H_
#define OPENMM_FLAVORS_FORCE_CACHE_H_

#include "StiffClock.h"
#include "openmm/Vec3.h"
#include <string>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/**
 * The forces of each force-group set a step reads (its slots), valid until positions change, so each set is
 * evaluated once per distinct set of positions; and whether the virtual sites are placed for the current positions.
 */
class ForceCache {
public:
    explicit ForceCache(bool hasVirtualSites) : hasVirtualSites(hasVirtualSites) {}
    /**
     * Sets the force-group set of each slot and whether its evaluation includes the energy (withEnergy, empty for
     * none: a Metropolis test reads the energy of these slots); every slot starts invalid.
     */
    void setSlots(const std::vector<int>& slotGroups, int numParticles,
                  const std::vector<bool>& withEnergy = std::vector<bool>());
    /** The energy of the forces of a slot that is evaluated with its energy, at the current positions. */
    double getEnergy(OpenMM::ContextImpl& context, int slot);
    /** The energy of the forces of groups at the current positions, evaluated without keeping forces. */
    double evaluateEnergy(OpenMM::ContextImpl& context, int groups);
    /**
     * The forces of a slot at the current positions, evaluated (virtual sites placed first) if not valid.  A clocked
     * read (clocked = true, a kick of stiff groups on the stiff clock) needs forces evaluated with the clock parameter
     * at clock: forces of the slot evaluated at another clock value are evaluated again, with the parameter set first.
     */
    const std::vector<OpenMM::Vec3>& get(OpenMM::ContextImpl& context, int slot, bool clocked = false,
                                         double clock = 0.0);
    /** Names the Context global parameter that clocked reads set (StepPlan's clocked kicks); "" for none. */
    void setClockParameter(const std::string& name) { clockParameter = name; }
    /** The forces a slot last held, valid or not (a Filtered flow reads those where it began). */
    const std::vector<OpenMM::Vec3>& last(int slot) const { return slots[slot].forces; }
    /** Positions changed: every slot and the virtual sites are out of date. */
    void invalidate();
    /** Places the virtual sites unless an evaluation at the current positions already did. */
    void placeVirtualSites(OpenMM::ContextImpl& context);

private:
    struct Slot {
        int groups;
        bool valid;
        SlotClock evaluatedAt;
        bool withEnergy = false;
        double energy = 0.0;
        std::vector<OpenMM::Vec3> forces;
    };
    std::string clockParameter;
    std::vector<Slot> slots;
    bool hasVirtualSites;
    bool virtualSitesPlaced = false;
};

} // namespace FlavorPlugin

#endif

#include "ForceCache.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferencePlatform.h"
#include <utility>

using namespace FlavorPlugin;
using namespace OpenMM;

void ForceCache::setSlots(const std::vector<int>& slotGroups, int numParticles, const std::vector<bool>& withEnergy) {
    slots.resize(slotGroups.size());
    for (size_t i = 0; i < slots.size(); ++i) {
        slots[i].groups = slotGroups[i];
        slots[i].valid = false;
        slots[i].withEnergy = i < withEnergy.size() && withEnergy[i];
        slots[i].forces.resize(numParticles);
    }
}

const std::vector<Vec3>& ForceCache::get(ContextImpl& context, int slotIndex, bool clocked, double clock) {
    Slot& slot = slots[slotIndex];
    // A slot evaluated at these positions with another clock value holds other forces.
    if (slot.valid && slot.evaluatedAt.serves(clocked, clock))
        return slot.forces;
    placeVirtualSites(context);
    if (clocked)
        context.setParameter(clockParameter, clock);
    slot.evaluatedAt = SlotClock{clocked, clock};
    slot.energy = context.calcForcesAndEnergy(true, slot.withEnergy, slot.groups);
    // Take the platform's force buffer instead of copying it; the platform refills whatever buffer it holds.
    auto* data = reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
    std::swap(*data->forces, slot.forces);
    slot.valid = true;
    return slot.forces;
}

double ForceCache::getEnergy(ContextImpl& context, int slot) {
    get(context, slot);
    return slots[slot].energy;
}

double ForceCache::evaluateEnergy(ContextImpl& context, int groups) {
    placeVirtualSites(context);
    return context.calcForcesAndEnergy(false, true, groups);
}

void ForceCache::invalidate() {
    for (Slot& slot : slots)
        slot.valid = false;
    virtualSitesPlaced = false;
}

void ForceCache::placeVirtualSites(ContextImpl& context) {
    if (hasVirtualSites && !virtualSitesPlaced)
        context.computeVirtualSites();
    virtualSitesPlaced = true;
}

#ifndef OPENMM_FLAVORS_STIFF_CLOCK_H_
#define OPENMM_FLAVORS_STIFF_CLOCK_H_

#include "FlowCheckpoint.h"
#include "internal/windowsExportFlavors.h"
#include <string>

namespace FlavorPlugin {

/** The stiff clock value a slot of forces was evaluated at, if any. */
struct SlotClock {
    bool clocked = false;
    double clock = 0.0;
    /** Whether these forces serve a read: a clocked read needs forces evaluated at its clock value. */
    bool serves(bool clockedRead, double readClock) const { return !clockedRead || (clocked && clock == readClock); }
};

/**
 * The stiff clock of a FlavorIntegrator (setStiffClockParameter), the same on every platform: it advances tau per
 * mesostep, and starts at the Context's time times tau/delta at the first step, whenever the time was set from
 * outside and whenever tau or delta changes.  A checkpoint carries its state.
 */
class OPENMM_EXPORT_FLAVORS StiffClock {
public:
    /** Names the Context parameter ("" for none) and the time scales.  Cheap when nothing changed. */
    void configure(const std::string& parameter, double microStep, double mesoStep);
    bool isOn() const { return !parameter.empty(); }
    const std::string& getParameter() const { return parameter; }
    /** The clock where a step that starts at the Context's time begins (ps). */
    double startStep(double time);
    /** The step ended at the Context's time: the clock advances tau. */
    void endStep(double time);
    const StiffClockState& getState() const { return state; }
    void setState(const StiffClockState& stored) { state = stored; }

private:
    std::string parameter;
    // Time NaN while it is off, so that a checkpoint without one starts it afresh.
    StiffClockState state;
    double advance = 0.0, ratio = 1.0;
};

} // namespace FlavorPlugin

#endif

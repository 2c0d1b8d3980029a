#include "internal/FlowSchedule.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using std::vector;

namespace {

SubFlow kick(double h, int groups) {
    return SubFlow{SubFlow::Kick, h, groups};
}

SubFlow drift(double h) {
    return SubFlow{SubFlow::Drift, h, 0};
}

SubFlow thermostat(double h) {
    return SubFlow{SubFlow::Thermostat, h, 0};
}

SubFlow stiffFlow(double h) {
    return SubFlow{SubFlow::StiffFlow, h, 0};
}

SubFlow harmonicFlow(double h) {
    return SubFlow{SubFlow::HarmonicFlow, h, 0};
}

SubFlow frozenDrift(double h) {
    return SubFlow{SubFlow::FrozenDrift, h, 0};
}

SubFlow frozenKick(double h, int groups) {
    return SubFlow{SubFlow::FrozenKick, h, groups};
}

bool composesExactly(const SubFlow& a, const SubFlow& b) {
    if (a.kind != b.kind || a.kind == SubFlow::FilteredStiffFlow || a.kind == SubFlow::FilteredKick)
        return false;
    return (a.kind != SubFlow::Kick && a.kind != SubFlow::FrozenKick) || a.groups == b.groups;
}

bool disjointKicksOverOneStep(const SubFlow& a, const SubFlow& b) {
    return a.kind == SubFlow::Kick && b.kind == SubFlow::Kick && a.h == b.h && (a.groups & b.groups) == 0;
}

/** The artificial FLAVOR (eq. (2.11) and its symmetric composition); see flavorSchedule(). */
Schedule artificialSchedule(const FlavorParameters& p) {
    const double delta = p.mesoStep, tau = p.microStep, rest = delta - tau;
    const int soft = p.integrationGroups & ~p.stiffGroups;
    const int stiff = p.integrationGroups & p.stiffGroups;
    const bool friction = p.friction > 0.0;
    const bool projected = p.averaging == FlavorIntegrator::ArtificialProjected;
    Schedule s;
    // The soft impulse over h; projected, its component along the frozen coordinates weighted by tau/delta.  The
    // two parts act at the same positions and commute; the plain kick goes on the side of the thermostat, so that
    // the two share one velocity projection (FlowStepRunner).
    auto softKick = [&](double h, bool closing) {
        const double plainPart = h * (tau / delta), frozenPart = h - plainPart;
        if (!projected) {
            s.push_back(kick(h, soft));
        } else if (closing) {
            s.push_back(frozenKick(frozenPart, soft));
            s.push_back(kick(plainPart, soft));
        } else {
            s.push_back(kick(plainPart, soft));
            s.push_back(frozenKick(frozenPart, soft));
        }
    };
    if (p.scheme == FlavorIntegrator::SymplecticEuler) {
        if (friction)
            s.push_back(thermostat(tau));
        softKick(delta, false);
        if (p.exactFastFlow) {
            s.push_back(harmonicFlow(tau));
        } else {
            // Eq. (2.13): q += tau v, then v -= tau M^-1 grad U at the new positions.
            s.push_back(drift(tau));
            s.push_back(kick(tau, stiff));
        }
        if (friction && !p.stiffFriction)
            s.push_back(thermostat(rest));
        s.push_back(frozenDrift(rest));
    } else if (friction && p.thermostatPlacement == FlavorIntegrator::Middle) {
        // B A O A, as LangevinMiddleIntegrator, on both time scales: the soft kick over delta, the frozen drift, the
        // microstep K_stiff(tau) D(tau/2) O D(tau/2), the frozen drift.  The soft coordinates drift delta/2 on each
        // side of the thermostat and the stiff ones tau/2; the step ends where both kicks act (the stiff
        // coordinates do not move in the frozen drift and the soft kick), so harmonic coordinates of either kind
        // keep their exact variance there.
        softKick(delta, false);
        s.push_back(frozenDrift(rest / 2));
        s.push_back(kick(tau, stiff));
        s.push_back(drift(tau / 2));
        s.push_back(thermostat(p.stiffFriction ? tau : delta));
        s.push_back(drift(tau / 2));
        s.push_back(frozenDrift(rest / 2));
    } else {
        const double edge = p.stiffFriction ? tau / 2 : delta / 2;
        if (friction)
            s.push_back(thermostat(edge));
        softKick(delta / 2, false);
        s.push_back(frozenDrift(rest / 2));
        if (p.exactFastFlow) {
            s.push_back(harmonicFlow(tau));
        } else {
            s.push_back(kick(tau / 2, stiff));
            s.push_back(drift(tau));
            s.push_back(kick(tau / 2, stiff));
        }
        s.push_back(frozenDrift(rest / 2));
        softKick(delta / 2, true);
        if (friction)
            s.push_back(thermostat(edge));
    }
    return simplifySchedule(s);
}

} // namespace

bool FlavorPlugin::isModeFlow(SubFlow::Kind kind) {
    return kind == SubFlow::StiffFlow || kind == SubFlow::HarmonicFlow || kind == SubFlow::FrozenDrift ||
           kind == SubFlow::FrozenKick || kind == SubFlow::FilteredStiffFlow || kind == SubFlow::FilteredKick;
}

Schedule FlavorPlugin::simplifySchedule(const Schedule& schedule) {
    Schedule result;
    for (const SubFlow& flow : schedule) {
        if (flow.h == 0.0 || (flow.kind == SubFlow::Kick && flow.groups == 0))
            continue;
        if (!result.empty() && composesExactly(result.back(), flow))
            result.back().h += flow.h;
        else if (!result.empty() && disjointKicksOverOneStep(result.back(), flow))
            result.back().groups |= flow.groups;
        else
            result.push_back(flow);
    }
    return result;
}

Schedule FlavorPlugin::flavorSchedule(const FlavorParameters& p) {
    if (p.averaging != FlavorIntegrator::Nonintrusive)
        return artificialSchedule(p);
    const double tau = p.microStep, rest = p.mesoStep - p.microStep;
    const int all = p.integrationGroups;
    const int soft = p.integrationGroups & ~p.stiffGroups;
    const bool friction = p.friction > 0.0;
    Schedule s;
    if (p.scheme == FlavorIntegrator::SymplecticEuler) {
        // Eq. (2.17); Langevin: eqs. (4.7) and (4.8).
        if (friction)
            s.push_back(thermostat(tau));
        s.push_back(kick(tau, all));
        s.push_back(drift(tau));
        if (friction && !p.stiffFriction)
            s.push_back(thermostat(rest));
        s.push_back(kick(rest, soft));
        s.push_back(drift(rest));
    } else {
        // Eq. (2.7); Langevin: eqs. (4.9) and (4.10).
        const double edge = p.stiffFriction ? tau / 2 : p.mesoStep / 2;
        if (friction)
            s.push_back(thermostat(edge));
        s.push_back(kick(tau / 2, all));
        s.push_back(drift(tau / 2));
        s.push_back(kick(rest / 2, soft));
        s.push_back(drift(rest));
        s.push_back(kick(rest / 2, soft));
        s.push_back(drift(tau / 2));
        s.push_back(kick(tau / 2, all));
        if (friction)
            s.push_back(thermostat(edge));
    }
    return simplifySchedule(s);
}

Schedule FlavorPlugin::impulseSchedule(const ImpulseParameters& p) {
    const double H = p.stepSize;
    const int soft = p.integrationGroups & ~p.stiffGroups;
    Schedule s;
    auto strang = [&](double h) {
        s.push_back(kick(h / 2, soft));
        s.push_back(stiffFlow(h));
        s.push_back(kick(h / 2, soft));
    };
    if (p.splitting == StochasticImpulseIntegrator::LieTrotter) {
        s.push_back(stiffFlow(H));
        s.push_back(kick(H, soft));
    } else if (p.splitting == StochasticImpulseIntegrator::Strang) {
        strang(H);
    } else if (p.splitting == StochasticImpulseIntegrator::Filtered ||
               p.splitting == StochasticImpulseIntegrator::Warped) {
        // The same flows; the runner's bias removal says whether the kicks are scaled or the flow warped.
        if (soft == 0) {
            s.push_back(stiffFlow(H));
        } else {
            s.push_back(SubFlow{SubFlow::FilteredStiffFlow, H, soft});
            s.push_back(SubFlow{SubFlow::FilteredKick, H, soft});
        }
    } else {
        const double c = 1.0 / (2.0 - std::cbrt(2.0));
        strang(c * H);
        strang((1 - 2 * c) * H);
        strang(c * H);
    }
    return simplifySchedule(s);
}

bool FlavorPlugin::isVelocityFlow(SubFlow::Kind kind) {
    return kind == SubFlow::Kick || kind == SubFlow::Thermostat;
}

StepPlan FlavorPlugin::compileStepPlan(const Schedule& schedule, bool constrained) {
    StepPlan plan;
    bool driftedInPass = false, onlyVelocityFlowsInPass = false;
    for (const SubFlow& flow : schedule) {
        const bool previousWasStiff = !plan.passes.empty() && isModeFlow(plan.passes.back().flows.back().kind);
        // With constraints only kicks and thermostats share a pass: one velocity projection after all of them is
        // the same as one after each (the projection is linear at fixed positions).
        const bool joinsUnderConstraints = isVelocityFlow(flow.kind) && onlyVelocityFlowsInPass;
        bool newPass = plan.passes.empty() || (constrained && !joinsUnderConstraints) || isModeFlow(flow.kind) ||
                       previousWasStiff || (flow.kind == SubFlow::Kick && driftedInPass);
        if (newPass) {
            plan.passes.emplace_back();
            driftedInPass = false;
            onlyVelocityFlowsInPass = true;
        }
        onlyVelocityFlowsInPass = onlyVelocityFlowsInPass && isVelocityFlow(flow.kind);
        int slot = -1;
        if (flow.kind == SubFlow::Kick || flow.kind == SubFlow::FrozenKick || flow.kind == SubFlow::FilteredStiffFlow ||
            flow.kind == SubFlow::FilteredKick) {
            auto found = std::find(plan.slotGroups.begin(), plan.slotGroups.end(), flow.groups);
            slot = (int)(found - plan.slotGroups.begin());
            if (found == plan.slotGroups.end())
                plan.slotGroups.push_back(flow.groups);
        }
        if (flow.kind == SubFlow::Drift)
            driftedInPass = true;
        plan.passes.back().flows.push_back(flow);
        plan.passes.back().slots.push_back(slot);
    }
    return plan;
}

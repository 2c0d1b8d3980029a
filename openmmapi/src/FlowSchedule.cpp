#include "internal/FlowSchedule.h"
#include "internal/PhysicalConstants.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using std::vector;

namespace {

/** Builds the sub-flows of one step, each with its length in the integrator's time scales. */
class ScheduleBuilder {
public:
    explicit ScheduleBuilder(double meso, double micro = 0.0) : meso(meso), micro(micro) {}
    /** h = a delta + b tau, computed as the caller computes it (value) so that the numbers stay as they were. */
    SubFlow flow(SubFlow::Kind kind, double value, double a, double b, int groups = 0) const {
        SubFlow f{kind, value, groups};
        f.length = StepLength{a, b};
        return f;
    }
    Schedule steps;
    const double meso, micro;
};

bool sameSettings(const SubFlow& a, const SubFlow& b) {
    return a.kind == b.kind && a.groups == b.groups && a.bath == b.bath && a.stiffBath == b.stiffBath &&
           a.frequency == b.frequency && a.zeroModes == b.zeroModes && a.response == b.response &&
           a.frozen == b.frozen && a.clocked == b.clocked && a.clock == b.clock && a.distance == b.distance;
}

/** Sub-flows that never merge with a neighbour of the same settings (their effect is not additive in h). */
bool composesNever(SubFlow::Kind kind) {
    return kind == SubFlow::FilteredStiffFlow || kind == SubFlow::FilteredKick || kind == SubFlow::HardWall ||
           kind == SubFlow::HardWallSpeed;
}

bool composesExactly(const SubFlow& a, const SubFlow& b) {
    return sameSettings(a, b) && !composesNever(a.kind);
}

bool disjointKicksOverOneStep(const SubFlow& a, const SubFlow& b) {
    return a.kind == SubFlow::Kick && b.kind == SubFlow::Kick && a.h == b.h && (a.groups & b.groups) == 0 &&
           !a.clocked && !b.clocked;
}

/** The artificial FLAVOR (eq. (2.11) and its symmetric composition); see flavorSchedule(). */
Schedule artificialSchedule(const FlavorParameters& p) {
    const double delta = p.mesoStep, tau = p.microStep, rest = delta - tau;
    const int soft = p.integrationGroups & ~p.stiffGroups;
    const int stiff = p.integrationGroups & p.stiffGroups;
    const bool friction = p.friction > 0.0;
    const bool projected = p.averaging == FlavorIntegrator::ArtificialProjected;
    const Bath bath{p.kT, p.friction};
    ScheduleBuilder b(delta, tau);
    Schedule& s = b.steps;
    auto kick = [&](double h, double a, double c, int groups) { s.push_back(b.flow(SubFlow::Kick, h, a, c, groups)); };
    auto drift = [&](double h, double a, double c) { s.push_back(b.flow(SubFlow::Drift, h, a, c)); };
    auto thermostat = [&](double h, double a, double c) {
        SubFlow f = b.flow(SubFlow::Thermostat, h, a, c);
        f.bath = bath;
        s.push_back(f);
    };
    auto frozenDrift = [&](double h, double a, double c) {
        SubFlow f = b.flow(SubFlow::FrozenDrift, h, a, c);
        f.frozen = p.frozen;
        s.push_back(f);
    };
    auto harmonicFlow = [&](double h) {
        SubFlow f = b.flow(SubFlow::HarmonicFlow, h, 0, 1);
        f.bath = f.stiffBath = Bath{p.kT, 0.0};
        s.push_back(f);
    };
    // The soft impulse over h (= a delta); projected, its component along the frozen coordinates weighted by
    // tau/delta.  The two parts act at the same positions and commute; the plain kick goes on the side of the
    // thermostat, so that the two share one velocity projection.
    auto softKick = [&](double h, double a, bool closing) {
        const double plainPart = h * (tau / delta), frozenPart = h - plainPart;
        SubFlow frozenKick = b.flow(SubFlow::FrozenKick, frozenPart, a, -a, soft);
        frozenKick.frozen = p.frozen;
        if (!projected) {
            kick(h, a, 0, soft);
        } else if (closing) {
            s.push_back(frozenKick);
            kick(plainPart, 0, a, soft);
        } else {
            kick(plainPart, 0, a, soft);
            s.push_back(frozenKick);
        }
    };
    if (p.scheme == FlavorIntegrator::SymplecticEuler) {
        if (friction)
            thermostat(tau, 0, 1);
        softKick(delta, 1, false);
        if (p.exactFastFlow) {
            harmonicFlow(tau);
        } else {
            // Eq. (2.13): q += tau v, then v -= tau M^-1 grad U at the new positions.
            drift(tau, 0, 1);
            kick(tau, 0, 1, stiff);
        }
        if (friction && !p.stiffFriction)
            thermostat(rest, 1, -1);
        frozenDrift(rest, 1, -1);
    } else if (friction && p.thermostatPlacement == FlavorIntegrator::Middle) {
        // B A O A, as LangevinMiddleIntegrator, on both time scales: the soft kick over delta, the frozen drift, the
        // microstep K_stiff(tau) D(tau/2) O D(tau/2), the frozen drift.  The soft coordinates drift delta/2 on each
        // side of the thermostat and the stiff ones tau/2; the step ends where both kicks act (the stiff
        // coordinates do not move in the frozen drift and the soft kick), so harmonic coordinates of either kind
        // keep their exact variance there.
        softKick(delta, 1, false);
        frozenDrift(rest / 2, 0.5, -0.5);
        kick(tau, 0, 1, stiff);
        drift(tau / 2, 0, 0.5);
        if (p.stiffFriction)
            thermostat(tau, 0, 1);
        else
            thermostat(delta, 1, 0);
        drift(tau / 2, 0, 0.5);
        frozenDrift(rest / 2, 0.5, -0.5);
    } else {
        const double edge = p.stiffFriction ? tau / 2 : delta / 2;
        const double edgeA = p.stiffFriction ? 0 : 0.5, edgeB = p.stiffFriction ? 0.5 : 0;
        if (friction)
            thermostat(edge, edgeA, edgeB);
        softKick(delta / 2, 0.5, false);
        frozenDrift(rest / 2, 0.5, -0.5);
        if (p.exactFastFlow) {
            harmonicFlow(tau);
        } else {
            kick(tau / 2, 0, 0.5, stiff);
            drift(tau, 0, 1);
            kick(tau / 2, 0, 0.5, stiff);
        }
        frozenDrift(rest / 2, 0.5, -0.5);
        softKick(delta / 2, 0.5, true);
        if (friction)
            thermostat(edge, edgeA, edgeB);
    }
    return simplifySchedule(s);
}

/**
 * Generalized hybrid Monte Carlo: O(h/2) [proposal] O(h/2), the deterministic proposal between its start and its
 * test of the energy of groups (the thermostats only with friction).
 */
Schedule metropolisSchedule(const Schedule& proposal, double h, const Bath& bath, int groups) {
    SubFlow thermostat{SubFlow::Thermostat, h / 2, 0};
    thermostat.bath = bath;
    thermostat.length = StepLength{0.5, 0.0};
    SubFlow start{SubFlow::ProposalStart, 0.0, groups}, test{SubFlow::ProposalTest, 0.0, groups};
    start.bath = test.bath = bath;
    Schedule s;
    if (bath.friction > 0.0)
        s.push_back(thermostat);
    s.push_back(start);
    s.insert(s.end(), proposal.begin(), proposal.end());
    s.push_back(test);
    if (bath.friction > 0.0)
        s.push_back(thermostat);
    return simplifySchedule(s);
}

bool isProposalMarker(SubFlow::Kind kind) {
    return kind == SubFlow::ProposalStart || kind == SubFlow::ProposalTest;
}

} // namespace

bool FlavorPlugin::isCoupledFlow(SubFlow::Kind kind) {
    return kind == SubFlow::StiffFlow || kind == SubFlow::HarmonicFlow || kind == SubFlow::FrozenDrift ||
           kind == SubFlow::FrozenKick || kind == SubFlow::FilteredStiffFlow || kind == SubFlow::FilteredKick ||
           isProposalMarker(kind) || kind == SubFlow::HardWall || kind == SubFlow::HardWallSpeed;
}

bool FlavorPlugin::isVelocityFlow(SubFlow::Kind kind) {
    return kind == SubFlow::Kick || kind == SubFlow::Thermostat;
}

Schedule FlavorPlugin::simplifySchedule(const Schedule& schedule) {
    Schedule result;
    for (const SubFlow& flow : schedule) {
        if ((flow.h == 0.0 && !isProposalMarker(flow.kind)) || (flow.kind == SubFlow::Kick && flow.groups == 0))
            continue;
        if (!result.empty() && composesExactly(result.back(), flow)) {
            result.back().h += flow.h;
            result.back().length.mesoSteps += flow.length.mesoSteps;
            result.back().length.microSteps += flow.length.microSteps;
        } else if (!result.empty() && disjointKicksOverOneStep(result.back(), flow)) {
            result.back().groups |= flow.groups;
        } else {
            result.push_back(flow);
        }
    }
    return result;
}

FlavorParameters FlavorPlugin::flavorParameters(const FlavorIntegrator& integrator) {
    FlavorParameters p{integrator.getScheme(),
                       integrator.getAveraging(),
                       integrator.getExactFastFlow(),
                       integrator.getMesoStep(),
                       integrator.getMicroStep(),
                       integrator.getStiffGroups(),
                       integrator.getIntegrationForceGroups(),
                       integrator.getFriction(),
                       integrator.getStiffFriction(),
                       integrator.getThermostatPlacement()};
    p.kT = BoltzmannKJPerMolK * integrator.getTemperature();
    p.stiffClock = !integrator.getStiffClockParameter().empty();
    p.metropolis = integrator.getMetropolis();
    return p;
}

Schedule FlavorPlugin::flavorSchedule(const FlavorParameters& p) {
    if (p.metropolis) {
        FlavorParameters proposal = p;
        proposal.metropolis = false;
        proposal.friction = 0.0;
        return metropolisSchedule(flavorSchedule(proposal), p.mesoStep, Bath{p.kT, p.friction}, p.integrationGroups);
    }
    if (p.averaging != FlavorIntegrator::Nonintrusive)
        return artificialSchedule(p);
    const double tau = p.microStep, rest = p.mesoStep - p.microStep;
    const int all = p.integrationGroups;
    const int soft = p.integrationGroups & ~p.stiffGroups;
    const bool friction = p.friction > 0.0;
    ScheduleBuilder b(p.mesoStep, tau);
    Schedule& s = b.steps;
    auto kick = [&](double h, double a, double c, int groups) { s.push_back(b.flow(SubFlow::Kick, h, a, c, groups)); };
    // A kick of all groups on the stiff clock, at the stiff time clock within the microstep.
    auto clockedKick = [&](double h, double a, double c, double clock) {
        SubFlow f = b.flow(SubFlow::Kick, h, a, c, all);
        f.clocked = p.stiffClock && (all & p.stiffGroups) != 0;
        f.clock = f.clocked ? clock : 0.0;
        s.push_back(f);
    };
    auto drift = [&](double h, double a, double c) { s.push_back(b.flow(SubFlow::Drift, h, a, c)); };
    auto thermostat = [&](double h, double a, double c) {
        SubFlow f = b.flow(SubFlow::Thermostat, h, a, c);
        f.bath = Bath{p.kT, p.friction};
        s.push_back(f);
    };
    if (p.scheme == FlavorIntegrator::SymplecticEuler) {
        // Eq. (2.17); Langevin: eqs. (4.7) and (4.8).
        if (friction)
            thermostat(tau, 0, 1);
        clockedKick(tau, 0, 1, 0.0);
        drift(tau, 0, 1);
        if (friction && !p.stiffFriction)
            thermostat(rest, 1, -1);
        kick(rest, 1, -1, soft);
        drift(rest, 1, -1);
    } else {
        // Eq. (2.7); Langevin: eqs. (4.9) and (4.10).
        const double edge = p.stiffFriction ? tau / 2 : p.mesoStep / 2;
        const double edgeA = p.stiffFriction ? 0 : 0.5, edgeB = p.stiffFriction ? 0.5 : 0;
        if (friction)
            thermostat(edge, edgeA, edgeB);
        clockedKick(tau / 2, 0, 0.5, 0.0);
        drift(tau / 2, 0, 0.5);
        kick(rest / 2, 0.5, -0.5, soft);
        drift(rest, 1, -1);
        kick(rest / 2, 0.5, -0.5, soft);
        drift(tau / 2, 0, 0.5);
        clockedKick(tau / 2, 0, 0.5, tau);
        if (friction)
            thermostat(edge, edgeA, edgeB);
    }
    return simplifySchedule(s);
}

ImpulseParameters FlavorPlugin::impulseParameters(const StochasticImpulseIntegrator& integrator) {
    ImpulseParameters p{integrator.getSplitting(), integrator.getStepSize(), integrator.getStiffGroups(),
                        integrator.getIntegrationForceGroups()};
    p.thermostatPlacement = integrator.getThermostatPlacement();
    p.bath = Bath{BoltzmannKJPerMolK * integrator.getTemperature(), integrator.getFriction()};
    p.stiffBath = Bath{BoltzmannKJPerMolK * integrator.getStiffModeTemperature(), integrator.getStiffModeFriction()};
    p.metropolis = integrator.getMetropolis();
    p.maxDrudeDistance = integrator.getMaxDrudeDistance();
    p.maxWarpedPhase = integrator.getMaxWarpedPhase();
    p.warpedFrictionScaling = integrator.getWarpedFrictionScaling();
    return p;
}

Schedule FlavorPlugin::impulseSchedule(const ImpulseParameters& p) {
    if (p.maxDrudeDistance > 0.0) {
        ImpulseParameters unwalled = p;
        unwalled.maxDrudeDistance = 0.0;
        Schedule s = impulseSchedule(unwalled);
        SubFlow wall{SubFlow::HardWall, p.stepSize, 0};
        wall.stiffBath = p.stiffBath;
        wall.distance = p.maxDrudeDistance;
        wall.length = StepLength{1.0, 0.0};
        // The positions before the closing kick, so that the kick reads the forces of the walled positions and the
        // next step reuses them (one force evaluation per step); the velocities after it, which in a kick-flow-kick
        // step are the ones that carry the pair's motion (before the kick a pair held out by its field moves inward at
        // (H/2) F/mu, which the kick cancels).
        const auto lastMove = std::find_if(s.rbegin(), s.rend(), [](const SubFlow& f) {
            return !isVelocityFlow(f.kind) && f.kind != SubFlow::FilteredKick;
        });
        s.insert(lastMove.base(), wall);
        wall.kind = SubFlow::HardWallSpeed;
        s.push_back(wall);
        return s;
    }
    if (p.metropolis) {
        ImpulseParameters proposal = p;
        proposal.metropolis = false;
        proposal.bath.friction = proposal.stiffBath.friction = 0.0;
        return metropolisSchedule(impulseSchedule(proposal), p.stepSize, p.bath, p.integrationGroups);
    }
    const double H = p.stepSize;
    const int soft = p.integrationGroups & ~p.stiffGroups;
    ScheduleBuilder b(H);
    Schedule& s = b.steps;
    auto stiffFlow = [&](SubFlow::Kind kind, double h, double a, int groups) {
        SubFlow f = b.flow(kind, h, a, 0, groups);
        f.bath = p.bath;
        f.stiffBath = p.stiffBath;
        if (kind != SubFlow::StiffFlow) {
            const bool warped = p.splitting == StochasticImpulseIntegrator::Warped;
            f.response = warped ? SubFlow::KickResponse::Plain : SubFlow::KickResponse::Scaled;
            f.frequency = warped ? SubFlow::StiffFrequency::Warped : SubFlow::StiffFrequency::Exact;
            if (warped)
                f.warp = WarpedFlowSettings{p.maxWarpedPhase, p.warpedFrictionScaling};
            if (p.thermostatPlacement == StochasticImpulseIntegrator::Middle)
                f.zeroModes = SubFlow::ZeroModeFlow::Middle;
        }
        s.push_back(f);
    };
    auto kick = [&](double h, double a) { s.push_back(b.flow(SubFlow::Kick, h, a, 0, soft)); };
    auto strang = [&](double h, double a) {
        kick(h / 2, a / 2);
        stiffFlow(SubFlow::StiffFlow, h, a, 0);
        kick(h / 2, a / 2);
    };
    if (p.splitting == StochasticImpulseIntegrator::LieTrotter) {
        stiffFlow(SubFlow::StiffFlow, H, 1, 0);
        kick(H, 1);
    } else if (p.splitting == StochasticImpulseIntegrator::Strang) {
        strang(H, 1);
    } else if (p.splitting == StochasticImpulseIntegrator::Filtered ||
               p.splitting == StochasticImpulseIntegrator::Warped) {
        if (soft == 0) {
            stiffFlow(SubFlow::StiffFlow, H, 1, 0);
        } else {
            stiffFlow(SubFlow::FilteredStiffFlow, H, 1, soft);
            stiffFlow(SubFlow::FilteredKick, H, 1, soft);
        }
    } else {
        const double c = 1.0 / (2.0 - std::cbrt(2.0));
        strang(c * H, c);
        strang((1 - 2 * c) * H, 1 - 2 * c);
        strang(c * H, c);
    }
    return simplifySchedule(s);
}

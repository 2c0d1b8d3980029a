#!/usr/bin/env python3
"""What correcting the Drude's slow response from the force history would do (docs/sim_drude.md section 8).

A step that evaluates the soft force f once per step gives each Drude mode x_(n+1) - T x_n + D x_(n-1) = b f_n, and
past H = 2/omega its response to a slow field is a heavier Drude's.  Adding b2 (f_n - 2 f_(n-1) + f_(n-2)) with
b2 / b = (1 + D) / (2 (1 + D - T)) - 1 / (omega H)^2 (a velocity increment in the opening kick, no extra force
evaluation) makes the Omega^2 term of the response exact.  This script measures the two prices of that term on the
SIM's Warped step (phase-limited at 2.05, the Drude's 20/ps bath, friction unscaled and scaled):

* the Drude-Drude coupling: where the soft force has stiffness lambda k along a Drude mode (SWM4-NDP: lambda from
  -0.38 to +0.66), the loop x_(n+1) - T x_n + D x_(n-1) = -lambda k (b f + b2 second difference) has a third root:
  the interval of lambda in which all roots stay in the unit disc, the Drude friction, and the largest flow phase,
  at which it reaches from -0.38 to what the step without the term holds on the stiff side;
* the phase: (1 - e^(-i Omega H))^2 = -(Omega H)^2 + i (Omega H)^3 + ..., so the response leads a field of frequency
  Omega as a Drude friction of -(b2 / b) omega^2 Omega^2 H^3 would make it lag, and heat flows into the molecules:
  heat_model.py's linear model (one Drude mode driving a libration-like mode of 100/ps), exact stationary
  temperatures with and without the correction, against that friction's prediction.

Writes force_history.json and force_history.png to --out.

    PYTHONPATH=build/python .venv/bin/python examples/drude_water/force_history.py [--out DIR]
"""

import argparse
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import heat_model  # noqa: E402

MAX_PHASE = 2.05
SOFTEST, STIFFEST = -0.38, 0.66  # the soft Hessian over SWM4-NDP's Drude coordinates, in units of the spring k
LIBRATION = 100.0  # 1/ps, heat_model.py's soft mode
STEPS_FS = (2.5, 3.0, 3.5, 4.0)
PHASES = tuple(np.round(np.arange(0.2, 2.051, 0.05), 2))


def recurrence(h, scaled, drude_friction=heat_model.DRUDE_FRICTION, max_phase=MAX_PHASE):
    """(T, D, b2 / b) of the Drude mode's position recurrence under the Warped step."""
    flow, gamma, _ = heat_model.warped_mode(h, max_phase, scaled, drude_friction)
    phi, _ = heat_model.mode_flow(flow, gamma, h)
    return np.trace(phi), np.linalg.det(phi), heat_model.history_ratio(phi, h)


def spectral_radius(trace, det, ratio, coupling):
    """Largest root of the closed loop when the soft force is -coupling k x along the mode (coupling = lambda)."""
    bc = coupling * (1 + det - trace)  # b times the soft stiffness, with the exact mean's b = (1 + D - T) / omega^2
    return max(abs(np.roots([1.0, -(trace - bc * (1 + ratio)), det - 2 * bc * ratio, bc * ratio])))


def stable_interval(trace, det, ratio):
    """The interval of lambda around 0 (within [-1, 1]) in which the loop is stable."""
    def stable(coupling):
        return spectral_radius(trace, det, ratio, coupling) <= 1 + 1e-12

    def edge(direction):
        # Walk out from 0 (the stable set need not be an interval out to +-1), then bisect the first crossing.
        inside = 0.0
        for outside in np.linspace(0.0, direction, 1001)[1:]:
            if not stable(outside):
                break
            inside = outside
        else:
            return direction
        for _ in range(40):
            middle = 0.5 * (inside + outside)
            inside, outside = (middle, outside) if stable(middle) else (inside, middle)
        return inside
    return edge(-1.0), edge(1.0)


def friction_holding(h, softest, stiffest):
    """The Drude friction (1/ps, unscaled) above which the corrected loop is stable from lambda = softest to
    stiffest."""
    def holds(gamma):
        low, high = stable_interval(*recurrence(h, False, gamma))
        return low <= softest and high >= stiffest
    low, high = heat_model.DRUDE_FRICTION, 20000.0
    if holds(low):
        return low
    for _ in range(30):
        middle = math.sqrt(low * high)
        low, high = (low, middle) if holds(middle) else (middle, high)
    return high


def response(trace, det, ratio, h, omega_field, history=True, coupling=0.0):
    """omega^2 times the Drude's response to a unit field of frequency omega_field (1 for a constant field without
    coupling), omega the frequency the step's exact mean is set for; coupling: a soft stiffness lambda k along the mode,
    kicked like the field (an anisotropic remainder, the Drude-Drude coupling)."""
    z = complex(math.cos(omega_field * h), math.sin(omega_field * h))
    s = 1 + det - trace
    kick = 1 + (ratio * (1 - 1 / z)**2 if history else 0)
    return s * kick / (z - trace + det / z + coupling * s * kick)


def lead_friction(ratio, h, omega_field=LIBRATION):
    """The Drude friction whose lag the correction's lead cancels at omega_field (negative: it leads)."""
    return -ratio * heat_model.DRUDE_OMEGA**2 * omega_field**2 * h**3


def phase_scan(h):
    """Per flow phase (the phase limit), the stable lambda with the history term and its lead friction at 100/ps:
    a smaller phase widens the interval and lengthens b2 / b."""
    scan = []
    for phase in PHASES:
        trace, det, ratio = recurrence(h, False, max_phase=phase)
        scan.append(dict(phase=phase, history_ratio=ratio, stable_with_history=stable_interval(trace, det, ratio),
                         stable_without=stable_interval(trace, det, 0.0), lead_friction_per_ps=lead_friction(ratio, h)))
    return scan


def rows(r):
    # heat_model.py's bilinear coupling c of the Drude mode to the soft mode, from r = c^2 / (k M Omega^2).
    bilinear = math.sqrt(r * heat_model.DRUDE_MU * heat_model.DRUDE_OMEGA**2 * heat_model.MOLECULE_MASS
                         * LIBRATION**2)
    true = heat_model.exact_temperature(bilinear, LIBRATION)
    # dT/dgamma of the true dynamics: what a Drude friction changed by the lead would do to the soft mode.
    slope = (heat_model.exact_temperature(bilinear, LIBRATION, drude_friction=25.0)
             - heat_model.exact_temperature(bilinear, LIBRATION, drude_friction=15.0)) / 10.0
    table = []
    for step_fs in STEPS_FS:
        h = step_fs * 1e-3
        row = dict(step_fs=step_fs)
        for scaled in (False, True):
            trace, det, ratio = recurrence(h, scaled)
            name = "scaled" if scaled else "unscaled"
            row[name] = dict(history_ratio=ratio, stable_with_history=stable_interval(trace, det, ratio),
                             stable_without=stable_interval(trace, det, 0.0),
                             soft_mode_K=heat_model.sim_temperature(h, bilinear, LIBRATION, MAX_PHASE, scaled)[0],
                             soft_mode_with_history_K=heat_model.sim_temperature(h, bilinear, LIBRATION, MAX_PHASE,
                                                                                 scaled, history=True)[0])
        ratio = row["scaled"]["history_ratio"]
        row["lead_friction_per_ps"] = lead_friction(ratio, h)
        row["predicted_with_history_K"] = true + slope * row["lead_friction_per_ps"]
        # What the running step holds on the stiff side (the phase limit was set for it), with the term too.
        held = row["unscaled"]["stable_without"][1]
        row["friction_holding_per_ps"] = friction_holding(h, SOFTEST, held)
        row["phases"] = phase_scan(h)
        covering = [p for p in row["phases"] if p["stable_with_history"][0] <= SOFTEST
                    and p["stable_with_history"][1] >= held]
        row["largest_phase_covering"] = max(covering, key=lambda p: p["phase"]) if covering else None
        table.append(row)
    return true, table


def plot(true, table, path):
    steps = [row["step_fs"] for row in table]
    fig, (band, lead, heat) = plt.subplots(1, 3, figsize=(16, 5))
    shown = next(row for row in table if row["step_fs"] == 3.5)
    phases = [p["phase"] for p in shown["phases"]]
    band.fill_between(phases, [p["stable_with_history"][0] for p in shown["phases"]],
                      [p["stable_with_history"][1] for p in shown["phases"]], color="tab:red", alpha=0.35,
                      label="stable with the history term")
    band.plot(phases, [p["stable_without"][1] for p in shown["phases"]], "k--",
              label="without it: upper edge (lower edge −1)")
    band.axhline(shown["unscaled"]["stable_without"][1], color="tab:blue", linestyle=":",
                 label=f"what the step holds at ω̃H = {MAX_PHASE}")
    band.axhspan(SOFTEST, STIFFEST, color="tab:gray", alpha=0.15, label=f"SWM4-NDP's λ: −{-SOFTEST} to +{STIFFEST}")
    band.set_xlabel("flow phase ω̃H (rad)")
    band.set_ylabel("soft stiffness along a Drude mode λ (units of k)")
    band.set_ylim(-1.05, 1.05)
    band.set_title("H = 3.5 fs, Drude bath 20/ps: stable λ", fontsize=10)
    band.legend(fontsize=8, loc="lower right")
    for row in table:
        lead.plot([p["phase"] for p in row["phases"]], [-p["lead_friction_per_ps"] for p in row["phases"]], "-",
                  label=f"H = {row['step_fs']:g} fs")
    lead.axhline(heat_model.DRUDE_FRICTION, color="black", linestyle=":", label="the Drude bath's friction (20/ps)")
    lead.set_yscale("log")
    lead.set_xlabel("flow phase ω̃H (rad)")
    lead.set_ylabel("−(friction equivalent to the lead) at Ω = 100/ps (1/ps)")
    lead.set_title("The history term's lead, as a negative Drude friction", fontsize=10)
    lead.legend(fontsize=8)
    heat.axhline(true, color="black", label="true dynamics")
    heat.plot(steps, [row["scaled"]["soft_mode_K"] for row in table], "v-", color="tab:orange",
              label="SIM, friction scaled")
    heat.plot(steps, [row["scaled"]["soft_mode_with_history_K"] for row in table], "o-", color="tab:red",
              label="SIM, friction scaled, with the history term")
    heat.plot(steps, [row["unscaled"]["soft_mode_with_history_K"] for row in table], "s-", color="tab:cyan",
              label="SIM, friction unscaled, with the history term")
    heat.plot(steps, [row["predicted_with_history_K"] for row in table], "x--", color="tab:brown",
              label="true dynamics, Drude friction 20/ps + the lead's")
    heat.set_xlabel("step H (fs)")
    heat.set_ylabel("temperature of the soft mode (K)")
    heat.set_title(f"Linear model (ω̃H ≤ {MAX_PHASE}): a soft mode of Ω = {LIBRATION:g}/ps", fontsize=10)
    heat.legend(fontsize=8)
    fig.suptitle("Correcting the Drude's Ω² response from the force history (b₂ second difference): "
                 "stability against the Drude–Drude coupling, and heat", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results",
                                                      "force_history"))
    parser.add_argument("--r", type=float, default=0.1, help="heat_model.py's coupling r (default 0.1)")
    args = parser.parse_args()
    if not 0 < args.r < 1:
        parser.error("--r must be in (0, 1) (got %g)" % args.r)
    true, table = rows(args.r)
    for row in table:
        s, u = row["scaled"], row["unscaled"]
        print(f"H = {row['step_fs']:g} fs: b2/b {s['history_ratio']:.3f}; stable λ with the term "
              f"[{u['stable_with_history'][0]:+.3f}, {u['stable_with_history'][1]:+.3f}] (friction unscaled), "
              f"[{s['stable_with_history'][0]:+.4f}, {s['stable_with_history'][1]:+.3f}] (scaled), without "
              f"[{s['stable_without'][0]:+.2f}, {s['stable_without'][1]:+.3f}]; that and λ = {SOFTEST} need a Drude "
              f"friction of {row['friction_holding_per_ps']:.0f}/ps; lead as a friction of "
              f"{row['lead_friction_per_ps']:.0f}/ps at Ω = {LIBRATION:g}/ps; soft mode {true:.2f} K true, "
              f"{s['soft_mode_K']:.2f} scaled, {s['soft_mode_with_history_K']:.2f} scaled with the term "
              f"(predicted {row['predicted_with_history_K']:.2f}), {u['soft_mode_with_history_K']:.2f} unscaled "
              f"with the term")
        cover = row["largest_phase_covering"]
        print(f"    stable from λ = {SOFTEST} to the step's own edge only for ω̃H ≤ {cover['phase']:.2f}, where the lead acts as a friction "
              f"of {cover['lead_friction_per_ps']:.0f}/ps" if cover else "    no phase ≥ 0.2 is stable from "
              f"λ = {SOFTEST} to the step's own edge")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "force_history.json"), "w") as f:
        json.dump(dict(r=args.r, omega_y_per_ps=LIBRATION, max_warped_phase=MAX_PHASE, softest=SOFTEST,
                       stiffest=STIFFEST, true_temperature_K=true, rows=table), f, indent=1)
    plot(true, table, os.path.join(args.out, "force_history.png"))


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Why a Warped SIM runs polarizable molecules cool, and what the friction scaling does about it, in the smallest
linear model that shows it: one Drude mode x (SWM4-NDP's reduced mass and omega = 1036/ps, cold bath 1 K at 20/ps)
coupled bilinearly, -c x y, to one libration-like soft mode y (mass 10 amu, Omega = 100/ps, 300 K at 5/ps).  The
coupling c is set by r, the fraction of y's stiffness that x's response takes away (r = c^2/(k M Omega^2)).

Every step here is linear with Gaussian noise, so each stationary covariance is exact: the true dynamics from the
continuous Lyapunov equation, a SIM step (Warped: kick, exact Ornstein-Uhlenbeck flow of x at the warped or phase-
limited frequency, kick; y with the Middle placement) from the discrete one.  Written in numpy from the definitions
in docs/sim_drude.md sections 4-7, independently of the plugin.  Prints and writes heat_model.json and
heat_model.png to --out: y's temperature against H for the true dynamics, the SIM unscaled and scaled, and the true
dynamics of a Drude (omega/omega_d)^2 heavier.
"""

import argparse
import json
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import scipy.linalg as sl  # noqa: E402

KB = 0.0083144626  # kJ/mol/K
DRUDE_MU = 15.19943 * 0.4 / 15.59943  # amu
DRUDE_OMEGA = 1036.0  # 1/ps
DRUDE_FRICTION, DRUDE_T = 20.0, 1.0
MOLECULE_MASS, TEMPERATURE, FRICTION = 10.0, 300.0, 5.0


def mode_flow(omega, gamma, h):
    """The exact flow of x'' = -omega^2 x - gamma x' + noise over h: transition and noise covariance for kT/m = 1."""
    a = np.array([[0.0, 1.0], [-omega * omega, -gamma]])
    van_loan = np.zeros((4, 4))
    van_loan[:2, :2], van_loan[:2, 2:], van_loan[2:, 2:] = -a, np.diag([0.0, 2 * gamma]), a.T
    e = sl.expm(van_loan * h)
    return sl.expm(a * h), e[2:, 2:].T @ e[:2, 2:]


def strang_static_response(phi, h):
    """The constant-force fixed point of K(h/2) E K(h/2) per unit force."""
    return np.linalg.solve(np.eye(2) - phi, phi @ [0.0, h / 2] + [0.0, h / 2])[0]


def warped_frequency(omega, gamma, h):
    low, high = 0.0, math.pi / h
    for _ in range(100):
        middle = 0.5 * (low + high)
        if strang_static_response(mode_flow(middle, gamma, h)[0], h) > 1 / omega**2:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


def warped_mode(h, max_phase, scaled, drude_friction=DRUDE_FRICTION):
    """(flow frequency, friction, half kick) of the Drude mode in a Warped step, limited and scaled as asked."""
    gamma = drude_friction
    for _ in range(20):
        flow = warped_frequency(DRUDE_OMEGA, gamma, h)
        if max_phase:
            flow = min(flow, max_phase / h)
        if not scaled:
            break
        gamma = drude_friction * (2 * math.sin(flow * h / 2) / (h * DRUDE_OMEGA))**2
    phi, _ = mode_flow(flow, gamma, h)
    # The half kick that keeps the exact mean: h/2 for the warped flow itself.
    kick = np.linalg.det(np.eye(2) - phi) / (2 * DRUDE_OMEGA**2 * phi[0, 1])
    return flow, gamma, kick


def history_ratio(phi, h):
    """b2 / b: the weight of the force history's second difference that cancels the Omega^2 error of the Drude's
    response (docs/sim_drude.md section 8), for a mode flow phi with the exact mean."""
    trace, det = np.trace(phi), np.linalg.det(phi)
    return (1 + det) / (2 * (1 + det - trace)) - 1 / (DRUDE_OMEGA * h)**2


def sim_temperature(h, coupling, omega_y, max_phase, scaled, history=False):
    """y's stationary temperature under the SIM step (state x, vx, y, vy and y one and two steps back); with history
    the opening kick of x adds (b2 / b) times the second difference of its soft force."""
    flow, gamma, a = warped_mode(h, max_phase, scaled)
    phi, noise = mode_flow(flow, gamma, h)
    k_y = MOLECULE_MASS * omega_y**2

    def kick(ax, ay):
        k = np.eye(6)
        k[1] += ax * np.array([0.0, 0.0, coupling, 0.0, 0.0, 0.0]) / DRUDE_MU
        k[3] += ay * np.array([coupling, 0.0, -k_y, 0.0, 0.0, 0.0]) / MOLECULE_MASS
        return k
    weight = 2 * a * coupling / DRUDE_MU * (history_ratio(phi, h) if history else 0.0)
    correction = np.eye(6)
    correction[1, 2:] += weight * np.array([1.0, 0.0, -2.0, 1.0])
    remember = np.eye(6)
    remember[4:] = 0.0
    remember[4, 2], remember[5, 4] = 1.0, 1.0
    flows = np.eye(6)
    flows[:2, :2] = phi
    drift, decay = np.array([[1.0, h / 2], [0.0, 1.0]]), math.exp(-FRICTION * h)
    flows[2:4, 2:4] = drift @ np.diag([1.0, decay]) @ drift
    q = np.zeros((6, 6))
    q[:2, :2] = noise * KB * DRUDE_T / DRUDE_MU
    q[2:4, 2:4] = drift @ np.diag([0.0, (1 - decay**2) * KB * TEMPERATURE / MOLECULE_MASS]) @ drift.T
    # Middle: y takes its full kick at the opening, x half kicks at both ends.
    closing = kick(a, 0.0)
    step = closing @ flows @ remember @ correction @ kick(a, h)
    if max(abs(np.linalg.eigvals(step))) >= 1:
        return math.nan, flow
    sigma = sl.solve_discrete_lyapunov(step, closing @ q @ closing.T)
    return MOLECULE_MASS * sigma[3, 3] / KB, flow


def exact_temperature(coupling, omega_y, drude_mu=DRUDE_MU, drude_friction=DRUDE_FRICTION):
    """y's stationary temperature under the true dynamics with a Drude of mass drude_mu and the same spring."""
    k = DRUDE_MU * DRUDE_OMEGA**2
    a = np.array([[0, 1, 0, 0], [-k / drude_mu, -drude_friction, coupling / drude_mu, 0], [0, 0, 0, 1],
                  [coupling / MOLECULE_MASS, 0, -omega_y**2, -FRICTION]])
    q = np.diag([0, 2 * drude_friction * KB * DRUDE_T / drude_mu, 0, 2 * FRICTION * KB * TEMPERATURE / MOLECULE_MASS])
    return MOLECULE_MASS * sl.solve_continuous_lyapunov(a, -q)[3, 3] / KB


def main():
    global FRICTION
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results"))
    parser.add_argument("--r", type=float, default=0.1, help="coupling: fraction of y's stiffness (default 0.1)")
    parser.add_argument("--omega-y", type=float, default=100.0, help="y's frequency Omega in 1/ps (default 100)")
    parser.add_argument("--max-warped-phase", type=float, default=2.05, help="setMaxWarpedPhase (default 2.05)")
    parser.add_argument("--friction", type=float, default=FRICTION, help="y's friction in 1/ps (default %(default)g)")
    args = parser.parse_args()
    if not args.friction > 0:
        parser.error("--friction must be positive (got %g)" % args.friction)
    FRICTION = args.friction
    coupling = math.sqrt(args.r * DRUDE_MU * DRUDE_OMEGA**2 * MOLECULE_MASS * args.omega_y**2)
    steps = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
    exact = exact_temperature(coupling, args.omega_y)
    rows = []
    for step_fs in steps:
        h = step_fs * 1e-3
        unscaled, flow = sim_temperature(h, coupling, args.omega_y, args.max_warped_phase, False)
        scaled, _ = sim_temperature(h, coupling, args.omega_y, args.max_warped_phase, True)
        mass_factor = 1 / (2 * math.sin(flow * h / 2) / (h * DRUDE_OMEGA))**2
        heavy = exact_temperature(coupling, args.omega_y, DRUDE_MU * mass_factor)
        rows.append(dict(step_fs=step_fs, flow_phase=flow * h, mass_factor=mass_factor, sim=unscaled,
                         sim_scaled=scaled, heavier_drude=heavy))
        print(f"H = {step_fs:g} fs (ω̃H {flow * h:.2f}, Drude {mass_factor:.2f}× heavier): true {exact:.2f} K, "
              f"SIM {unscaled:.2f} K, scaled {scaled:.2f} K, true with the heavier Drude {heavy:.2f} K")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "heat_model.json"), "w") as f:
        json.dump(dict(r=args.r, omega_y_per_ps=args.omega_y, max_warped_phase=args.max_warped_phase,
                       friction_per_ps=FRICTION, true_temperature_K=exact, rows=rows), f, indent=1)
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    ax.axhline(exact, color="black", label="true dynamics")
    ax.plot(steps, [r["sim"] for r in rows], "o-", color="tab:cyan", label="SIM Warped (friction γ)")
    ax.plot(steps, [r["sim_scaled"] for r in rows], "v-", color="tab:orange",
            label="SIM Warped, friction scaled by (ω_d/ω)²")
    ax.plot(steps, [r["heavier_drude"] for r in rows], "x--", color="tab:brown",
            label="true dynamics, Drude (ω/ω_d)² heavier")
    ax.set_xlabel("step H (fs)")
    ax.set_ylabel("temperature of the soft mode (K)")
    ax.set_title(f"Linear model: Drude mode (ω = {DRUDE_OMEGA:g}/ps, 1 K bath at 20/ps) driving a soft mode\n"
                 f"(Ω = {args.omega_y:g}/ps, 300 K at {FRICTION:g}/ps, r = {args.r:g}); "
                 f"ω̃H ≤ {args.max_warped_phase:g}", fontsize=10)
    ax.legend(fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "heat_model.png"), dpi=110)


if __name__ == "__main__":
    main()

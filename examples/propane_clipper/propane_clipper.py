#!/usr/bin/env python3
"""Nonlinear two-dimensional molecular clipper (exaggerated propane): the FLAVORS paper, section 6.5,
eqs. (6.9)-(6.12), Fig. 6.11.

    H = sum_i |p_i|^2/(2 m_i) + K_r/2 [(r1 - r0)^2 + (r2 - r0)^2] + K_theta/2 (cos(theta) - cos(theta0))^2

Unitless, exaggerated parameters of the paper: m = (15, 14, 15), r0 = 1.53, K_r = 8370, theta0 = 109.5 degrees,
K_theta = 4.31; start [x1, y1, x2, y2, x3, y3] = [0, 0, 1.533, 0, 2.6136, 1.0826] and momenta m v =
[-0.4326, -1.6656, 0.1253, 0.2877, -1.1465, 1.1909] (Fig. 6.11).  The paper gives no simulation time: T = 200
here (--T), about 20 periods of the bending motion.  Three particles in the x-y plane (z = 0): the bonds are a
HarmonicBondForce in force group 1 (stiff), the angle term a CustomAngleForce in group 0 (soft).

Runs: the paper's induced symplectic FLAVOR (2.5)+(2.9), FlavorIntegrator(0.1, 0.01) SymplecticEuler, beside the
paper's symplectic Euler at h = 0.01 (FlavorIntegrator(h, h) SymplecticEuler); h = 0.01 does not resolve the bonds
(h omega_bond ~ 0.34), so the reference is velocity Verlet (OpenMM's VerletIntegrator) at h = 5e-4 with its own
error by step halving; also the Verlet-scheme FLAVOR and the H_eff system (K_r times tau/delta) integrated finely.
Slow variables: the bond angle theta and the orientation phi of the vector from atom 1 to atom 3; fast: r1, r2.

    PYTHONPATH=build/python .venv/bin/python examples/propane_clipper/propane_clipper.py [--quick] [--out DIR]
"""
import math
import os

import numpy as np
import openmm as mm

from flavorbench import reporting, scenes
from flavorbench.systems import SOFT_GROUP, STIFF_GROUP

MASSES = (15.0, 14.0, 15.0)
START = [(0.0, 0.0), (1.533, 0.0), (2.6136, 1.0826)]
MOMENTA = [(-0.4326, -1.6656), (0.1253, 0.2877), (-1.1465, 1.1909)]


class PropaneClipper:
    name = "propane_clipper"
    title = "FLAVORS paper eqs. (6.9)-(6.12), Fig. 6.11: exaggerated propane"
    slow_unit = "rad"

    def __init__(self, k_r, r0, k_theta, theta0_deg):
        self.k_r, self.r0, self.k_theta = k_r, r0, k_theta
        self.cos0 = math.cos(math.radians(theta0_deg))
        self.positions = [mm.Vec3(x, y, 0.0) for x, y in START]
        self.velocities = [(px / m, py / m, 0.0) for (px, py), m in zip(MOMENTA, MASSES)]

    def system(self, scale):
        system = mm.System()
        for m in MASSES:
            system.addParticle(m)
        bonds = mm.HarmonicBondForce()  # k/2 (r - r0)^2
        bonds.addBond(0, 1, self.r0, scale * self.k_r)
        bonds.addBond(1, 2, self.r0, scale * self.k_r)
        bonds.setForceGroup(STIFF_GROUP)
        angle = mm.CustomAngleForce("0.5*k_theta*(cos(theta)-cos0)^2")
        angle.addGlobalParameter("k_theta", self.k_theta)
        angle.addGlobalParameter("cos0", self.cos0)
        angle.addAngle(0, 1, 2, [])
        angle.setForceGroup(SOFT_GROUP)
        system.addForce(bonds)
        system.addForce(angle)
        return system

    def coords(self, run):
        q, v = run["q"][:, :, :2], run["v"][:, :, :2]
        b1, b2 = q[:, 0] - q[:, 1], q[:, 2] - q[:, 1]
        u1, u2 = v[:, 0] - v[:, 1], v[:, 2] - v[:, 1]
        r1, r2 = np.linalg.norm(b1, axis=1), np.linalg.norm(b2, axis=1)
        cos = np.sum(b1 * b2, axis=1) / (r1 * r2)
        end = q[:, 2] - q[:, 0]
        masses = np.array(MASSES)
        return {"r1": r1, "r2": r2, "theta": np.arccos(np.clip(cos, -1, 1)), "cos": cos,
                "phi": np.unwrap(np.arctan2(end[:, 1], end[:, 0])),
                "r1dot": np.sum(b1 * u1, axis=1) / r1, "r2dot": np.sum(b2 * u2, axis=1) / r2,
                "K": 0.5 * np.sum(masses[None, :] * np.sum(v * v, axis=2), axis=1)}

    def slow(self, run):
        c = self.coords(run)
        return {"theta": c["theta"], "phi": c["phi"]}

    def fast(self, run):
        c = self.coords(run)
        return {"r1": c["r1"], "r2": c["r2"], "(r1-r0)^2": (c["r1"] - self.r0) ** 2,
                "(r2-r0)^2": (c["r2"] - self.r0) ** 2, "r1dot^2": c["r1dot"] ** 2, "r2dot^2": c["r2dot"] ** 2}

    def fast_signal(self, run):
        return self.coords(run)["r1"]

    def energies(self, run):
        c = self.coords(run)
        return (c["K"], 0.5 * self.k_theta * (c["cos"] - self.cos0) ** 2,
                0.5 * self.k_r * ((c["r1"] - self.r0) ** 2 + (c["r2"] - self.r0) ** 2))


def main():
    ap = reporting.parser(__doc__, PropaneClipper.name)
    ap.add_argument("--T", type=float, default=None, help="simulated time (default 200; 20 with --quick)")
    ap.add_argument("--delta", type=float, default=0.1)
    ap.add_argument("--tau", type=float, default=0.01)
    ap.add_argument("--h", type=float, default=0.01, help="symplectic Euler step (the paper's)")
    ap.add_argument("--href", type=float, default=None, help="reference step (default 5e-4; 1e-3 with --quick)")
    ap.add_argument("--k-r", type=float, default=8370.0)
    ap.add_argument("--k-theta", type=float, default=4.31)
    args = ap.parse_args()

    T = args.T if args.T is not None else (20.0 if args.quick else 200.0)
    href = args.href if args.href is not None else (1e-3 if args.quick else 5e-4)
    p = {"T": T, "delta": args.delta, "tau": args.tau, "h": args.h, "href": href, "h_eff": href,
         "sample": args.delta, "fine_sample": 0.01, "refine": [2] if args.quick else [2, 4, 10],
         "period_window": min(T, 20.0), "zoom": min(T, 4.0), "zoom_end": min(T, 40.0), "avg_window": 5.0,
         "masses": MASSES, "r0": 1.53, "K_r": args.k_r, "theta0_deg": 109.5, "K_theta": args.k_theta,
         "positions": START, "momenta": MOMENTA, "quick": args.quick}
    sc = PropaneClipper(args.k_r, p["r0"], args.k_theta, p["theta0_deg"])
    T_checks = scenes.checkpoints(T, (0.1, 0.5, 1.0))

    runs, _ = scenes.run_all(sc, p)
    out = scenes.summarize(sc, runs, p, T_checks)
    scenes.print_summary(sc, out, T_checks, ["theta", "phi"], ["r1", "(r1-r0)^2", "(r2-r0)^2", "r1dot^2"])
    # Bond-stretch frequencies of the linearized molecule at the start, for tau*omega and delta*tau*omega^2.
    out["bond_omega"] = bond_frequencies(sc)
    out["slow_period_reference"] = scenes.mean_period(runs["reference"]["t"], sc.coords(runs["reference"])["theta"])
    print(f"\nbond-stretch omega at the start: {out['bond_omega']}; tau*omega_max = "
          f"{p['tau'] * max(out['bond_omega']):.3f}, delta*tau*omega_max^2 = "
          f"{p['delta'] * p['tau'] * max(out['bond_omega']) ** 2:.3f}; bending period (reference) = "
          f"{out['slow_period_reference']:.3f}")

    os.makedirs(args.out, exist_ok=True)
    png = os.path.join(args.out, f"{sc.name}.png")
    deg = 180 / math.pi
    scenes.plot(sc, runs, out, p, png, [
        ("bond angle θ(t) (slow)", lambda r: deg * sc.coords(r)["theta"], "slow", "θ (degrees)"),
        (f"θ(t), last {p['zoom_end']:g} ps of the run", lambda r: deg * sc.coords(r)["theta"], "slow_end",
         "θ (degrees)"),
        ("orientation φ of atom 1 → atom 3 (slow)", lambda r: sc.coords(r)["phi"], "slow", "φ (rad)"),
        ("bond length r₁(t) (fast), zoom", lambda r: sc.coords(r)["r1"], "fast", "r₁ (nm)"),
        ("bond length r₂(t) (fast), zoom", lambda r: sc.coords(r)["r2"], "fast", "r₂ (nm)"),
        (f"r₁(t): running mean and mean ± std over {p['avg_window']:g} ps", lambda r: sc.coords(r)["r1"], "band",
         "r₁ (nm)"),
    ])
    data = {"scene": "FLAVORS paper section 6.5, eqs. (6.9)-(6.12), Fig. 6.11", "platform": "Reference",
            "openmm_version": mm.__version__, "parameters": p, **out,
            "series": scenes.series(runs, lambda r: {k: sc.coords(r)[k] for k in ("theta", "phi", "r1", "r2")})}
    js = os.path.join(args.out, f"{sc.name}.json")
    reporting.write_json(js, data)
    print(f"\nwrote {js} and {png}")


def bond_frequencies(sc):
    """Bond-stretch frequencies: the mass-weighted Hessian of the bond energy alone at the starting configuration."""
    q = np.array([[x, y] for x, y in START])
    m = np.repeat(MASSES, 2)
    hess = np.zeros((6, 6))
    for i, j in ((0, 1), (1, 2)):
        d = q[j] - q[i]
        r = np.linalg.norm(d)
        u = d / r
        # k [u u^T + (1 - r0/r)(I - u u^T)] per bond, with the usual +- block signs.
        block = sc.k_r * (np.outer(u, u) + (1 - sc.r0 / r) * (np.eye(2) - np.outer(u, u)))
        for a, b, s in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            hess[2 * a:2 * a + 2, 2 * b:2 * b + 2] += s * block
    w2 = np.linalg.eigvalsh(hess / np.sqrt(np.outer(m, m)))
    # The two largest are the stretches; the rest are rigid motions (one is slightly off zero: r1 != r0 at start).
    return [float(math.sqrt(max(x, 0.0))) for x in w2[-2:]]


if __name__ == "__main__":
    main()

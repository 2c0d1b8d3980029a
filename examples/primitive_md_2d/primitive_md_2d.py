#!/usr/bin/env python3
"""Nonlinear two-dimensional primitive molecular dynamics: the FLAVORS paper, section 6.4, eq. (6.8), Fig. 6.9.

    H = (p_x^2 + p_y^2)/2 + omega^2/2 (sqrt(x^2 + y^2) - r0)^2 + x^2/(x^2 + y^2)
      = p_r^2/2 + p_theta^2/(2 r^2) + omega^2/2 (r - r0)^2 + cos(theta)^2

omega = 500, x(0) = 1.1, y(0) = 0.8, p(0) = 0, T = 100 (Fig. 6.9); r0 is not given in the paper: r0 = 1 here
(--r0).  One unit-mass particle in the x-y plane (z = 0), tied to a fixed hinge at the origin: the stiff bond is a
CustomExternalForce in force group 1, the soft angular term x^2/(x^2 + y^2) a CustomExternalForce in group 0.

Runs: the paper's induced symplectic FLAVOR (2.5)+(2.9), FlavorIntegrator(0.01, 2e-4) SymplecticEuler, beside the
paper's symplectic Euler at h = 2e-4 (FlavorIntegrator(h, h) SymplecticEuler); a velocity Verlet reference
(OpenMM's VerletIntegrator) with its own error by step halving; the Verlet-scheme FLAVOR; and the H_eff system
(omega^2 times tau/delta) integrated finely.  Slow variables: the angle theta and the angular momentum
L = x p_y - y p_x (the stiff force is central, so dL/dt = sin(2 theta) has no fast part); fast: r.

    PYTHONPATH=build/python .venv/bin/python examples/primitive_md_2d/primitive_md_2d.py [--quick] [--out DIR]
"""
import math
import os

import numpy as np
import openmm as mm

from flavorbench import reporting, scenes
from flavorbench.systems import SOFT_GROUP, STIFF_GROUP


class PrimitiveMD2D:
    name = "primitive_md_2d"
    title = "FLAVORS paper eq. (6.8), Fig. 6.9: particle on a stiff spring hinged at the origin"
    slow_unit = "rad"

    def __init__(self, omega, r0, x0, y0):
        self.omega, self.r0 = omega, r0
        self.positions = [mm.Vec3(x0, y0, 0.0)]
        self.velocities = [(0.0, 0.0, 0.0)]

    def system(self, scale):
        system = mm.System()
        system.addParticle(1.0)
        stiff = mm.CustomExternalForce("0.5*k*(sqrt(x^2+y^2)-r0)^2")
        stiff.addGlobalParameter("k", scale * self.omega ** 2)
        stiff.addGlobalParameter("r0", self.r0)
        stiff.addParticle(0, [])
        stiff.setForceGroup(STIFF_GROUP)
        soft = mm.CustomExternalForce("x^2/(x^2+y^2)")
        soft.addParticle(0, [])
        soft.setForceGroup(SOFT_GROUP)
        system.addForce(stiff)
        system.addForce(soft)
        return system

    @staticmethod
    def coords(run):
        x, y = run["q"][:, 0, 0], run["q"][:, 0, 1]
        vx, vy = run["v"][:, 0, 0], run["v"][:, 0, 1]
        r = np.hypot(x, y)
        return {"x": x, "y": y, "vx": vx, "vy": vy, "r": r, "theta": np.arctan2(y, x),
                "L": x * vy - y * vx, "p_r": (x * vx + y * vy) / r}

    def slow(self, run):
        c = self.coords(run)
        return {"theta": c["theta"], "L": c["L"]}

    def fast(self, run):
        c = self.coords(run)
        return {"r": c["r"], "(r-r0)^2": (c["r"] - self.r0) ** 2, "1/r^2": 1 / c["r"] ** 2, "p_r^2": c["p_r"] ** 2}

    def fast_signal(self, run):
        return self.coords(run)["r"]

    def energies(self, run):
        c = self.coords(run)
        return (0.5 * (c["vx"] ** 2 + c["vy"] ** 2), c["x"] ** 2 / c["r"] ** 2,
                0.5 * self.omega ** 2 * (c["r"] - self.r0) ** 2)


def main():
    ap = reporting.parser(__doc__, PrimitiveMD2D.name)
    ap.add_argument("--omega", type=float, default=500.0)
    ap.add_argument("--r0", type=float, default=1.0, help="rest length of the bond (not stated in the paper)")
    ap.add_argument("--T", type=float, default=None, help="simulated time (default 100; 5 with --quick)")
    ap.add_argument("--delta", type=float, default=0.01)
    ap.add_argument("--tau", type=float, default=2e-4)
    ap.add_argument("--h", type=float, default=2e-4, help="symplectic Euler step (the paper's)")
    ap.add_argument("--href", type=float, default=None, help="reference step (default 4e-5; 1e-4 with --quick)")
    args = ap.parse_args()

    T = args.T if args.T is not None else (5.0 if args.quick else 100.0)
    href = args.href if args.href is not None else (1e-4 if args.quick else 4e-5)
    p = {"T": T, "delta": args.delta, "tau": args.tau, "h": args.h, "href": href, "h_eff": 1e-4,
         "sample": args.delta, "fine_sample": 2e-3, "refine": [2] if args.quick else [2, 4],
         "period_window": min(T, 2.0), "zoom": min(T, 0.5), "zoom_end": min(T, 10.0), "avg_window": 1.0,
         "omega": args.omega, "r0": args.r0, "x0": 1.1, "y0": 0.8, "quick": args.quick}
    sc = PrimitiveMD2D(args.omega, args.r0, p["x0"], p["y0"])
    T_checks = scenes.checkpoints(T, (0.1, 0.5, 1.0))

    runs, _ = scenes.run_all(sc, p)
    out = scenes.summarize(sc, runs, p, T_checks)
    scenes.print_summary(sc, out, T_checks, ["theta", "L"], ["r", "(r-r0)^2", "1/r^2", "p_r^2"])
    out["theta0"] = math.atan2(p["y0"], p["x0"])

    os.makedirs(args.out, exist_ok=True)
    png = os.path.join(args.out, f"{sc.name}.png")
    scenes.plot(sc, runs, out, p, png, [
        ("angle θ(t) (slow)", lambda r: sc.coords(r)["theta"], "slow", "θ (rad)"),
        (f"θ(t), last {p['zoom_end']:g} ps of the run", lambda r: sc.coords(r)["theta"], "slow_end", "θ (rad)"),
        ("angular momentum L = x p_y − y p_x (slow)", lambda r: sc.coords(r)["L"], "slow", "L (amu nm² ps⁻¹)"),
        ("spring length r(t) (fast), zoom", lambda r: sc.coords(r)["r"], "fast", "r (nm)"),
        (f"r(t): running mean and mean ± std over {p['avg_window']:g} ps", lambda r: sc.coords(r)["r"], "band",
         "r (nm)"),
    ])
    data = {"scene": "FLAVORS paper section 6.4, eq. (6.8), Fig. 6.9", "platform": "Reference",
            "openmm_version": mm.__version__, "parameters": p, **out,
            "series": scenes.series(runs, lambda r: {k: sc.coords(r)[k] for k in ("theta", "L", "r")})}
    js = os.path.join(args.out, f"{sc.name}.json")
    reporting.write_json(js, data)
    print(f"\nwrote {js} and {png}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Hamiltonian system with nonlinear stiff and soft potentials: the FLAVORS paper, section 6.2, eq. (6.6), Fig. 6.2.

    H = p_y^2/2 + p_x^2/2 + y^6/eps + (x - y)^4,   eps = 1e-6,  y(0) = 1.1, x(0) = 2.2, p(0) = 0,  T = 2

Two unit-mass particles on the x axis: particle 0 carries y, particle 1 carries x.  Stiff y^6/eps:
CustomExternalForce on particle 0 (force group 1); soft (x - y)^4: CustomCompoundBondForce on the x coordinates
(group 0; not CustomBondForce "r^4", whose force is 0/0 at r = 0).

Runs: the paper's induced symplectic FLAVOR (2.5)+(2.9), FlavorIntegrator(1e-3, 1e-5) SymplecticEuler, beside the
paper's symplectic Euler at h = 1e-5 (FlavorIntegrator(h, h) SymplecticEuler); a velocity Verlet reference
(OpenMM's VerletIntegrator) with its own error by step halving; the Verlet-scheme FLAVOR; and the H_eff system
(stiff term times tau/delta, i.e. eps -> eps delta/tau) integrated finely, which is what a FLAVOR follows to leading
order.  Slow variable: x (and p_x); fast: y.

    PYTHONPATH=build/python .venv/bin/python examples/nonlinear_stiff_soft/nonlinear_stiff_soft.py [--quick] [--out DIR]
"""
import os

import openmm as mm

from flavorbench import reporting, scenes
from flavorbench.systems import SOFT_GROUP, STIFF_GROUP


class NonlinearStiffSoft:
    name = "nonlinear_stiff_soft"
    title = "FLAVORS paper eq. (6.6), Fig. 6.2: H = p²/2 + y⁶/ε + (x − y)⁴"
    slow_unit = "nm"

    def __init__(self, eps, x0, y0):
        self.eps = eps
        self.positions = [mm.Vec3(y0, 0, 0), mm.Vec3(x0, 0, 0)]
        self.velocities = [(0.0, 0.0, 0.0), (0.0, 0.0, 0.0)]

    def system(self, scale):
        system = mm.System()
        system.addParticle(1.0)
        system.addParticle(1.0)
        stiff = mm.CustomExternalForce("stiffness*x^6")
        stiff.addGlobalParameter("stiffness", scale / self.eps)
        stiff.addParticle(0, [])
        stiff.setForceGroup(STIFF_GROUP)
        soft = mm.CustomCompoundBondForce(2, "(x2-x1)^4")
        soft.addBond([0, 1], [])
        soft.setForceGroup(SOFT_GROUP)
        system.addForce(stiff)
        system.addForce(soft)
        return system

    @staticmethod
    def coords(run):
        q, v = run["q"], run["v"]
        return q[:, 0, 0], q[:, 1, 0], v[:, 0, 0], v[:, 1, 0]

    def slow(self, run):
        _, x, _, px = self.coords(run)
        return {"x": x, "p_x": px}

    def fast(self, run):
        y, x, py, _ = self.coords(run)
        return {"y^2": y * y, "y^6/eps": y ** 6 / self.eps, "p_y^2": py * py, "x-y": x - y}

    def fast_signal(self, run):
        return self.coords(run)[0]

    def energies(self, run):
        y, x, py, px = self.coords(run)
        return 0.5 * (py * py + px * px), (x - y) ** 4, y ** 6 / self.eps


def main():
    ap = reporting.parser(__doc__, NonlinearStiffSoft.name)
    ap.add_argument("--eps", type=float, default=1e-6)
    ap.add_argument("--T", type=float, default=None, help="simulated time (default 2; 0.2 with --quick)")
    ap.add_argument("--delta", type=float, default=1e-3)
    ap.add_argument("--tau", type=float, default=1e-5)
    ap.add_argument("--h", type=float, default=1e-5, help="symplectic Euler step (the paper's VE)")
    ap.add_argument("--href", type=float, default=None, help="reference step (default 1e-6; 5e-6 with --quick)")
    args = ap.parse_args()

    T = args.T if args.T is not None else (0.2 if args.quick else 2.0)
    href = args.href if args.href is not None else (5e-6 if args.quick else 1e-6)
    p = {"T": T, "delta": args.delta, "tau": args.tau, "h": args.h, "href": href, "h_eff": href,
         "sample": args.delta, "fine_sample": 1e-4, "refine": [2] if args.quick else [2, 4],
         "period_window": min(T, 0.2), "zoom": min(T, 0.06), "avg_window": 0.05,
         "eps": args.eps, "x0": 2.2, "y0": 1.1, "quick": args.quick}
    sc = NonlinearStiffSoft(args.eps, p["x0"], p["y0"])
    T_checks = scenes.checkpoints(T, (0.25, 0.5, 1.0))

    runs, _ = scenes.run_all(sc, p)
    out = scenes.summarize(sc, runs, p, T_checks)
    scenes.print_summary(sc, out, T_checks, ["x", "p_x"], ["y^2", "y^6/eps", "p_y^2"])

    os.makedirs(args.out, exist_ok=True)
    png = os.path.join(args.out, f"{sc.name}.png")
    scenes.plot(sc, runs, out, p, png, [
        ("x(t) (slow)", lambda r: sc.coords(r)[1], "slow", "x (nm)"),
        ("x(t) − y(t) (slow, modulated by the fast y), zoom", lambda r: sc.coords(r)[1] - sc.coords(r)[0], "fast",
         "x − y (nm)"),
        ("y(t) (fast), zoom", lambda r: sc.coords(r)[0], "fast", "y (nm)"),
        (f"x(t) − y(t): running mean and mean ± std over {p['avg_window']:g} ps",
         lambda r: sc.coords(r)[1] - sc.coords(r)[0], "band", "x − y (nm)"),
        (f"y(t): running mean and mean ± std over {p['avg_window']:g} ps", lambda r: sc.coords(r)[0], "band",
         "y (nm)"),
    ])
    data = {"scene": "FLAVORS paper section 6.2, eq. (6.6), Fig. 6.2", "platform": "Reference",
            "openmm_version": mm.__version__, "parameters": p, **out,
            "series": scenes.series(runs, lambda r: {"x": sc.coords(r)[1], "y": sc.coords(r)[0]})}
    js = os.path.join(args.out, f"{sc.name}.json")
    reporting.write_json(js, data)
    print(f"\nwrote {js} and {png}")


if __name__ == "__main__":
    main()

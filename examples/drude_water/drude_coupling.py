#!/usr/bin/env python3
"""Where SWM4-NDP's Drude-Drude coupling and the field's curvature come from: the first shell or farther out.

Two routes past Warped's step limit would evaluate part of the soft force more often than once per step: the part
that moves the Drudes fast.  If the field at a Drude came from its first shell of neighbours, a force of the pairs
within an oxygen-oxygen distance r_c (a few thousand pair terms, against the hundred thousand of the real-space sum
and the reciprocal sum) could be evaluated at H/2 and the rest at H.  This script measures, on the scene's water (256
molecules at water's density, equilibrated as temperature_probe.py's start):

* the soft Hessian over the Drude coordinates, in units of the spring k (Warped is stable while
  (1 + lambda) sin^2(phase/2) < 1 along every direction): by central differences of OpenMM's soft forces, and its
  part from the charges of the molecules within r_c of a Drude's oxygen (smoothly switched off over the last 0.1 nm;
  analytic); their extreme eigenvalues, and how collective the stiffest directions are (participation, weight on
  longitudinal plane waves of the box's smallest wave vectors);
* the soft force's curvature along the trajectory, the second difference f(t + 2H) - 2 f(t + H) + f(t) of the force
  on each Drude pair's relative coordinate (the Omega^2 term that makes a once-per-step Drude heavier, docs/
  sim_drude.md section 8), and the share of its mean square that the molecules beyond r_c carry.

Writes drude_coupling.json and prints the tables.

    PYTHONPATH=build/python .venv/bin/python examples/drude_water/drude_coupling.py [--frames 2] [--out DIR]
"""

import argparse
import itertools
import json
import math
import os
import sys

import numpy as np
import openmm
import openmm.unit as unit

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import drude_water  # noqa: E402
from flavorbench import hessian  # noqa: E402

SHELLS = (0.35, 0.45, 0.6)  # nm, oxygen-oxygen
SWITCH_WIDTH = 0.1  # nm
CURVATURE_STEPS_FS = (2.0, 2.5, 3.0, 3.5, 4.0)
SAMPLE_FS = 0.5


def switch(r, cutoff):
    """1 below cutoff - SWITCH_WIDTH, 0 beyond cutoff, the quintic smoothstep between."""
    s = np.clip((r - (cutoff - SWITCH_WIDTH)) / SWITCH_WIDTH, 0.0, 1.0)
    return 1 - s**3 * (10 - 15 * s + 6 * s * s)


def relative(pair_forces, drude_masses, core_masses):
    """The force on each pair's relative coordinate from the forces on its Drude and core."""
    return (core_masses * pair_forces[0] - drude_masses * pair_forces[1]) / (core_masses + drude_masses)


class Shells:
    """The molecules of the water and, for positions x and box edge L, the field of each Drude's shell: the charges of
    the other molecules whose oxygen is within r_c of its own, weighted by switch(r_OO)."""

    def __init__(self, analysis):
        self.analysis = analysis
        self.charges = analysis.charges
        self.blocks = analysis.blocks

    def neighbours(self, x, box, i, cutoff):
        o = x[self.analysis.cores]
        d = o - o[i]
        d -= box * np.round(d / box)
        weights = switch(np.linalg.norm(d, axis=1), cutoff)
        weights[i] = 0.0
        return np.nonzero(weights > 0)[0], weights

    def pair_forces(self, x, box, cutoff):
        """The shell's forces on each pair's Drude ([0]) and core ([1]), kJ/mol/nm."""
        a = self.analysis
        forces = np.zeros((2, len(a.drudes), 3))
        for i in range(len(a.drudes)):
            near, weights = self.neighbours(x, box, i, cutoff)
            sources = self.blocks[near].ravel()
            w = np.repeat(weights[near], self.blocks.shape[1])
            for row, target in enumerate((a.drudes[i], a.cores[i])):
                d = x[target] - x[sources]
                d -= box * np.round(d / box)
                r = np.linalg.norm(d, axis=1)
                weighted = (self.charges[sources] * w / r**3)[:, None] * d
                forces[row, i] = drude_water.ONE_4PI_EPS0 * self.charges[target] * weighted.sum(0)
        return forces

    def relative_forces(self, x, box, cutoff):
        """The shell's force on each pair's relative coordinate, (m_O f_D - m_D f_O) / M (kJ/mol/nm)."""
        a = self.analysis
        return relative(self.pair_forces(x, box, cutoff), a.masses[a.drudes][:, None], a.masses[a.cores][:, None])

    def drude_hessian(self, x, box, cutoff):
        """The shell's Hessian over the Drude coordinates (3n x 3n, kJ/mol/nm^2)."""
        a = self.analysis
        index = {p: k for k, p in enumerate(a.drudes)}
        n = len(a.drudes)
        hessian = np.zeros((3 * n, 3 * n))
        for i in range(n):
            near, weights = self.neighbours(x, box, i, cutoff)
            target = a.drudes[i]
            for j in near:
                for source in self.blocks[j]:
                    if self.charges[source] == 0:
                        continue
                    d = x[target] - x[source]
                    d -= box * np.round(d / box)
                    r = np.linalg.norm(d)
                    # The force on the target, K q_t q_s w d / r^3, has gradient K q_t q_s w (I/r^3 - 3 d d^T / r^5)
                    # in the target's position and its negative in the source's; the Hessian is minus that.
                    block = drude_water.ONE_4PI_EPS0 * self.charges[target] * self.charges[source] * weights[j] * (
                        np.eye(3) / r**3 - 3 * np.outer(d, d) / r**5)
                    hessian[3 * i:3 * i + 3, 3 * i:3 * i + 3] -= block
                    if source in index:
                        k = index[source]
                        hessian[3 * i:3 * i + 3, 3 * k:3 * k + 3] += block
        return 0.5 * (hessian + hessian.T)


def soft_drude_hessian(context, x, drudes, step=hessian.STEP_NM):
    """The Hessian of the soft forces (force group 0) over the Drude coordinates by central differences."""
    return hessian.hessian_over(context, x, drudes, 1, step)


def wave_weights(vector, x_drudes, box, longitudinal=True, shells=2):
    """The weight of a unit vector over the Drude coordinates on the box's plane waves of |k| <= shells 2 pi / L,
    polarized along k (longitudinal) or across it."""
    total = 0.0
    for m in itertools.product(range(-shells, shells + 1), repeat=3):
        if m == (0, 0, 0) or sum(c * c for c in m) > shells**2:
            continue
        k = 2 * math.pi / box * np.array(m, dtype=float)
        unit_k = k / np.linalg.norm(k)
        phase = np.exp(1j * x_drudes @ k) / math.sqrt(len(x_drudes))
        if longitudinal:
            polarizations = [unit_k]
        else:
            first = np.cross(unit_k, [1.0, 0.0, 0.0] if abs(unit_k[0]) < 0.9 else [0.0, 1.0, 0.0])
            first /= np.linalg.norm(first)
            polarizations = [first, np.cross(unit_k, first)]
        for e in polarizations:
            total += abs(np.vdot((phase[:, None] * e).ravel(), vector))**2
    return total


def hessian_rows(hessian_full, shells_hessians, spring, x_drudes, box):
    values, vectors = np.linalg.eigh(hessian_full / spring)
    stiffest = []
    for column in range(len(values) - 1, len(values) - 9, -1):
        v = vectors[:, column]
        share = (v.reshape(-1, 3)**2).sum(1)
        stiffest.append(dict(lam=float(values[column]), participation=float(1 / np.sum(share**2) / len(share)),
                             longitudinal=float(wave_weights(v, x_drudes, box)),
                             transverse=float(wave_weights(v, x_drudes, box, False))))
    rows = dict(full=[float(values[0]), float(values[-1])], stiffest=stiffest, shells={})
    for cutoff, h in shells_hessians.items():
        near = np.linalg.eigvalsh(h / spring)
        far = np.linalg.eigvalsh((hessian_full - h) / spring)
        rows["shells"][str(cutoff)] = dict(shell=[float(near[0]), float(near[-1])],
                                           beyond=[float(far[0]), float(far[-1])])
    return rows


def curvature_shares(full, shell_forces):
    """For each step H of CURVATURE_STEPS_FS: the mean square of the second difference of the relative forces, and
    the share of it of what lies beyond each shell."""
    rows = []
    for step_fs in CURVATURE_STEPS_FS:
        lag = int(round(step_fs / SAMPLE_FS))

        def second(a):
            return a[2 * lag:] - 2 * a[lag:-lag] + a[:-2 * lag]
        total = float((second(full)**2).sum(-1).mean())
        rows.append(dict(step_fs=step_fs, rms_second_difference=math.sqrt(total),
                         beyond_share={str(c): float((second(full - s)**2).sum(-1).mean() / total)
                                       for c, s in shell_forces.items()}))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=2, help="frames for the Hessians, 1 ps apart (default 2)")
    parser.add_argument("--samples", type=int, default=400, help=f"force samples {SAMPLE_FS:g} fs apart (default 400)")
    parser.add_argument("--molecules", type=int, default=256, help="molecules (default 256)")
    parser.add_argument("--out", default=".", help="folder for drude_coupling.json (default .)")
    args = parser.parse_args()
    if args.frames < 1 or args.samples < 2 * int(round(max(CURVATURE_STEPS_FS) / SAMPLE_FS)) + 2:
        parser.error("--frames must be at least 1 and --samples long enough for the largest step's second difference")
    system, _, positions, box = drude_water.build_water(args.molecules)
    analysis = drude_water.Analysis(system)
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
    spring = drude_water.drude_spring(drude, 0)
    shells = Shells(analysis)
    platform = openmm.Platform.getPlatformByName("CPU")
    state = drude_water.equilibrated_state(system, positions, 1.0, 2000, 7)
    integrator = drude_water.make_integrator("DrudeLangevin", SAMPLE_FS, 8)
    context = openmm.Context(system, integrator, platform, {"Threads": "2"})
    context.setState(state)
    probe = openmm.Context(system, openmm.VerletIntegrator(0.001), platform, {"Threads": "2"})
    report = dict(molecules=args.molecules, box_nm=box, spring_kj_mol_nm2=spring, shells_nm=SHELLS,
                  switch_width_nm=SWITCH_WIDTH, frames=[])
    for frame in range(args.frames):
        if frame:
            integrator.step(int(round(1000 / SAMPLE_FS)))
        x = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)
        full = soft_drude_hessian(probe, x, analysis.drudes)
        rows = hessian_rows(full, {c: shells.drude_hessian(x, box, c) for c in SHELLS}, spring,
                            x[analysis.drudes], box)
        report["frames"].append(rows)
        print(f"frame {frame}: lambda {rows['full'][0]:+.3f} .. {rows['full'][1]:+.3f}; " + "; ".join(
            f"r_c {c}: shell {v['shell'][0]:+.3f} .. {v['shell'][1]:+.3f}, beyond {v['beyond'][0]:+.3f} .. "
            f"{v['beyond'][1]:+.3f}" for c, v in rows["shells"].items()), flush=True)
    full_forces, shell_forces = [], {c: [] for c in SHELLS}
    m_d, m_o = analysis.masses[analysis.drudes][:, None], analysis.masses[analysis.cores][:, None]
    for _ in range(args.samples):
        state = context.getState(getPositions=True, getForces=True, groups=1)
        x = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
        f = state.getForces(asNumpy=True).value_in_unit(unit.kilojoule_per_mole / unit.nanometer)
        full_forces.append(relative(np.array([f[analysis.drudes], f[analysis.cores]]), m_d, m_o))
        for c in SHELLS:
            shell_forces[c].append(shells.relative_forces(x, box, c))
        integrator.step(1)
    report["curvature"] = curvature_shares(np.array(full_forces), {c: np.array(s) for c, s in shell_forces.items()})
    print("| H (fs) | rms second difference (kJ/mol/nm) | " + " | ".join(f"share beyond {c} nm" for c in SHELLS) + " |")
    print("|---|---|" + "---|" * len(SHELLS))
    for row in report["curvature"]:
        print(f"| {row['step_fs']:g} | {row['rms_second_difference']:.1f} | " +
              " | ".join(f"{row['beyond_share'][str(c)]:.3f}" for c in SHELLS) + " |")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "drude_coupling.json"), "w") as f:
        json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()

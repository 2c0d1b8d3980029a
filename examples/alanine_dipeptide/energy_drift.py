#!/usr/bin/env python3
"""Where the FLAVOR heats alanine dipeptide: the total energy's drift without a thermostat (friction 0), per setting,
from --starts independent equilibrated states (LangevinMiddle 1 fs, friction 1/ps, --gap ps between them), --length
ps from each; and the drift of the stiff potential energy (groups 1-2: the heavy-atom bonds and the angles of the
non-planar centres) and of the kinetic energy of the heavy atoms and of the hydrogens.  Each drift is the slope of a
least-squares line through the frames (every 24 fs), its mean over the starts with the standard error of that mean.
Settings use alanine_dipeptide.py's --peers syntax; "lm:STEP[:hmrM]" is VerletIntegrator here (no friction), and
every FLAVOR runs with friction 0.

    OPENMM_CPU_THREADS=1 PYTHONPATH=... python examples/alanine_dipeptide/energy_drift.py [--settings ...]
        [--starts N] [--length PS] [--gap PS] [--out JSON]
"""
import argparse
import json
import math
import os
import sys
import time

os.environ.setdefault("OPENMM_CPU_THREADS", "1")

import numpy as np  # noqa: E402
import openmm as mm  # noqa: E402
import openmm.app as app  # noqa: E402
import openmm.unit as unit  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import alanine_dipeptide as scene  # noqa: E402

DEFAULT = ("lm:1,lm:4:hmr1.5,flavor:8:1:hmr3,flavor:8:0.5:hmr3,flavor:8:1:hmr3:allangles,flavor:6:1:hmr3:bonds,"
           "flavor:4:1:hmr3,flavor:4:1,flavor:8:1:hmr3:edges")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--settings", default=DEFAULT)
    p.add_argument("--starts", type=int, default=8)
    p.add_argument("--length", type=float, default=40.0, help="ps without a thermostat from each start (40)")
    p.add_argument("--gap", type=float, default=5.0, help="ps of LangevinMiddle 1 fs between starts (5)")
    p.add_argument("--out", default="energy_drift.json")
    args = p.parse_args()
    began = time.time()
    pdb = app.PDBFile(scene.PDB)
    forcefield = app.ForceField("amber14-all.xml", "implicit/obc2.xml")
    platform = mm.Platform.getPlatformByName("CPU")
    properties = {"Threads": os.environ["OPENMM_CPU_THREADS"]}
    system = scene.make_system(forcefield, pdb.topology)
    integrator = mm.LangevinMiddleIntegrator(scene.TEMPERATURE, scene.FRICTION, 1e-3)
    integrator.setRandomNumberSeed(777)
    context = mm.Context(system, integrator, platform, properties)
    context.setPositions(pdb.positions)
    mm.LocalEnergyMinimizer.minimize(context)
    context.setVelocitiesToTemperature(scene.TEMPERATURE * unit.kelvin, 777)
    integrator.step(20000)
    starts = []
    for _ in range(args.starts):
        integrator.step(int(round(args.gap * 1000)))
        starts.append(context.getState(getPositions=True, getVelocities=True))
    results = []
    for spec in args.settings.split(","):
        peer = scene.parse_peer(spec)
        sys_ = scene.make_system(forcefield, pdb.topology, peer["hmr"])
        terms = scene.Terms(sys_, pdb.topology, pdb.getPositions(asNumpy=True).value_in_unit(unit.nanometer))
        slopes = {"total": [], "stiff potential": [], "kinetic heavy": [], "kinetic H": []}
        failed = None
        for k, start in enumerate(starts):
            if peer["kind"] == "lm":
                integ = mm.VerletIntegrator(peer["step"] * 1e-3)
            else:
                peer["friction"] = 0.0
                integ = scene.make_integrator(peer, 99 + k)
            ctx = mm.Context(sys_, integ, platform, properties)
            ctx.setPositions(start.getPositions())
            ctx.setVelocities(start.getVelocities())
            steps = int(round(scene.FRAME_FS / peer["step"]))
            series = {key: [] for key in slopes}
            try:
                for _ in range(int(round(args.length * 1000 / scene.FRAME_FS))):
                    integ.step(steps)
                    state = ctx.getState(getVelocities=True, getEnergy=True)
                    v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
                    ke = 0.5 * terms.mass * np.sum(v * v, axis=1)
                    pe = state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)
                    stiff = ctx.getState(getEnergy=True, groups={scene.BOND_GROUP, scene.ANGLE_GROUP})
                    if not math.isfinite(pe):
                        raise mm.OpenMMException("non-finite energy")
                    series["total"].append(pe + ke.sum())
                    series["stiff potential"].append(stiff.getPotentialEnergy().value_in_unit(
                        unit.kilojoule_per_mole))
                    series["kinetic heavy"].append(ke[~terms.hydrogen].sum())
                    series["kinetic H"].append(ke[terms.hydrogen].sum())
            except mm.OpenMMException as error:
                failed = "start %d: %s" % (k, error)
                break
            t = np.arange(1, len(series["total"]) + 1) * scene.FRAME_FS * 1e-3
            for key, values in series.items():
                slopes[key].append(float(np.polyfit(t, values, 1)[0]))
            del ctx, integ
        record = {"setting": spec, "name": peer["name"] if peer["kind"] == "flavor" else
                  "Verlet %g fs%s" % (peer["step"], "" if peer["hmr"] is None else " HMR %g amu" % peer["hmr"])}
        if failed:
            record["failed"] = failed
        for key, values in slopes.items():
            if values:
                record[key] = float(np.mean(values))
                record[key + "_error"] = float(np.std(values, ddof=1) / math.sqrt(len(values))) \
                    if len(values) > 1 else float("nan")
        results.append(record)
        print("| %s | %s |%s" % (record["name"], " | ".join(
            "%+.2f ± %.2f" % (record[k], record[k + "_error"]) if k in record else "—" for k in slopes),
            (" failed: " + failed) if failed else ""), flush=True)
    with open(args.out, "w", encoding="utf-8") as f:
        json.dump({"command": " ".join(sys.argv), "seconds": time.time() - began, "starts": args.starts,
                   "length_ps": args.length, "gap_ps": args.gap, "results": results}, f, indent=1)
    print("%.0f s; wrote %s" % (time.time() - began, args.out))


if __name__ == "__main__":
    main()

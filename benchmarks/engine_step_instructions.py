#!/usr/bin/env python3
"""Instructions per step of the openmm-flavors step engine on the two molecular steps it is tuned for, counted by
valgrind's callgrind (load-independent), CPU platform with one thread:

  - villin: the protein recipe (FlavorIntegrator, ArtificialProjected, Middle placement, delta = 2.5 fs, tau = 1 fs,
    bonds and the angles of non-planar centres frozen; examples/villin, 8,867 atoms with PME);
  - drude_water: StochasticImpulseIntegrator, Warped splitting with the Middle placement at H = 2.5 fs, cold Drude
    bath (examples/drude_water, 256 SWM4-NDP molecules with PME), and drude_water_dl, DrudeLangevinIntegrator at 1 fs
    on the same system from the same state (the peer its speed is compared with);
  - flexible_water: the flexible-water recipe (FlavorIntegrator, ArtificialProjected, Middle placement, delta = 6 fs,
    tau = 0.5 fs, O-H bonds and H-O-H angles frozen; examples/flexible_water, 501 TIP3P molecules with PME), and
    flexible_water_lm, LangevinMiddleIntegrator at 2 fs on the same system from the same state, the step it is
    compared with;
  - drude_protein: StochasticImpulseIntegrator (Warped, Middle, H = 2 fs, the 0.02-nm wall) on alanine dipeptide in
    Drude-2019 with 250 SWM4-NDP molecules (examples/drude_protein), and drude_protein_dl, DrudeLangevinIntegrator at
    1 fs with the same wall from the same state: on the CPU platform OpenMM runs DrudeLangevin through its Reference
    code, so instructions are the fair cost there; drude_ions and drude_ions_dl the same on NaCl in SWM4-NDP
    (examples/drude_ions, 4 Na+/Cl- pairs in 248 waters).  For these the frozen stage's share is reported too: the
    functions of FrozenDistances and of its solver SparseLDLT (what inlining leaves of them).

Each step is run from one saved state for a short and a long number of steps in a child process under callgrind;
the difference is the cost of a step.  Reported: all instructions per step, and those of the engine's own functions
(the libraries libOpenMMFlavors*), the part a change of the engine can move.  The states are saved once in
DIR/engine_step_instructions/ and reused by later runs (--fresh saves them again), so two builds are compared from
the same start.

    PYTHONPATH=build/python .venv/bin/python benchmarks/engine_step_instructions.py [--out DIR] [--fresh]  # ~15 min
        [--scenes SCENE ...]

Needs valgrind (apt-get install valgrind).  Output: a table on stdout and DIR/engine_step_instructions.json
(default results/bench).
"""
import argparse
import json
import os
import subprocess
import sys

from flavorbench import _config
from flavorbench.callgrind import per_step, require_valgrind, scene_module

SCENES = {"villin": (3, 9), "drude_water": (10, 40), "drude_water_dl": (10, 40), "flexible_water": (3, 11),
          "flexible_water_lm": (3, 11), "drude_protein": (3, 9), "drude_protein_dl": (3, 9), "drude_ions": (10, 40),
          "drude_ions_dl": (10, 40)}
# Scenes that start from another scene's saved state.
STATE_OF = {"flexible_water_lm": "flexible_water", "drude_protein_dl": "drude_protein", "drude_water_dl": "drude_water",
            "drude_ions_dl": "drude_ions"}
# Each scene's step (fs), for the instructions per simulated ps.
STEP_FS = {"villin": 2.5, "drude_water": 2.5, "drude_water_dl": 1.0, "flexible_water": 6.0, "flexible_water_lm": 2.0,
           "drude_protein": 2.0, "drude_protein_dl": 1.0, "drude_ions": 2.0, "drude_ions_dl": 1.0}
# The frozen stage's functions (FrozenDistances.cpp and its solver).
FROZEN_STAGE = ("FrozenDistances", "SparseLDLT", "assembleB")


def make_villin():
    import openmm
    import openmm.app as app
    import openmm.unit as unit
    villin = scene_module("villin")
    pdb = app.PDBFile(villin.PDB)
    system = villin.make_system(app.ForceField("amber14-all.xml", "amber14/tip3p.xml"), pdb.topology)
    name, factory = next(p for p in villin.peers([(2.5, 1.0, "bonds+nonplanar angles", True)])
                         if p[0].startswith("FLAVOR"))

    def start():
        integrator = openmm.LangevinMiddleIntegrator(300, 1, 0.002)
        context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
        context.setPositions(pdb.positions)
        openmm.LocalEnergyMinimizer.minimize(context, 10, 200)
        context.setVelocitiesToTemperature(300 * unit.kelvin, 7)
        integrator.step(20)
        return context.getState(getPositions=True, getVelocities=True)

    return name, system, factory, start


def make_drude_water(kind="WarpedMiddle"):
    drude_water = scene_module("drude_water")
    system, _, positions, _ = drude_water.build_water(256)

    def start():
        return drude_water.equilibrated_state(system, positions, 1.0, 100, 1, threads=1)

    if kind == "DrudeLangevin":
        return "DrudeLangevin 1 fs", system, lambda: drude_water.make_integrator(kind, 1.0, 5), start
    return "SIM WarpedMiddle H=2.5 fs", system, lambda: drude_water.make_integrator(kind, 2.5, 5), start


def flexible_water_system():
    flexible_water = scene_module("flexible_water")
    forcefield, modeller = flexible_water.build_box(501)
    return flexible_water, modeller, flexible_water.make_system(forcefield, modeller.topology, False)


def flexible_water_start(flexible_water, modeller, system):
    import openmm
    import openmm.unit as unit

    def start():
        integrator = openmm.LangevinMiddleIntegrator(flexible_water.TEMPERATURE, 1, 0.0005)
        integrator.setRandomNumberSeed(3)
        context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
        context.setPositions(modeller.positions)
        openmm.LocalEnergyMinimizer.minimize(context, 10, 200)
        context.setVelocitiesToTemperature(flexible_water.TEMPERATURE * unit.kelvin, 7)
        integrator.step(400)
        return context.getState(getPositions=True, getVelocities=True)

    return start


def make_flexible_water():
    flexible_water, modeller, system = flexible_water_system()
    name, _, factory, _ = flexible_water.flavor_peer("ArtificialProjected", 6.0, 0.5, True, True)
    return name, system, lambda: factory(5), flexible_water_start(flexible_water, modeller, system)


def make_flexible_water_lm():
    flexible_water, modeller, system = flexible_water_system()
    name, _, factory, _ = flexible_water.langevin_peer(2.0)
    return name, system, lambda: factory(5), flexible_water_start(flexible_water, modeller, system)


def make_drude_forcefield_scene(scene, kind):
    """drude_protein (alanine dipeptide in 250 waters) or drude_ions (4 NaCl pairs in 248 waters), Drude-2019: the SIM
    at 2 fs on the System after separateDrudeSprings or DrudeLangevin at 1 fs on the original, both with the 0.02-nm
    wall."""
    import openmm
    drude_ions = scene_module("drude_ions")
    if scene == "drude_protein":
        unsplit, _, positions = scene_module("drude_protein").build(250, 0.8)
    else:
        unsplit, _, positions = drude_ions.build(248, 4, 0.8, 1)
    system, step_fs = unsplit, 1.0
    if kind == "WarpedMiddle":
        system, step_fs = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(unsplit)), 2.0
        drude_ions.StochasticImpulseIntegrator.separateDrudeSprings(system, drude_ions.SPRING_GROUP)

    def factory():
        integrator = drude_ions.make_integrator(kind, step_fs, 5)
        integrator.setMaxDrudeDistance(0.02)
        return integrator

    return (f"{kind} {step_fs:g} fs, wall 0.02 nm", system, factory,
            lambda: drude_ions.equilibrated(unsplit, positions, 1, 0.2, minimize=False))


MAKERS = {"villin": make_villin, "drude_water": make_drude_water,
          "drude_water_dl": lambda: make_drude_water("DrudeLangevin"), "flexible_water": make_flexible_water,
          "flexible_water_lm": make_flexible_water_lm,
          **{scene + suffix: (lambda scene=scene, kind=kind: make_drude_forcefield_scene(scene, kind))
             for scene in ("drude_protein", "drude_ions")
             for suffix, kind in (("", "WarpedMiddle"), ("_dl", "DrudeLangevin"))}}


def child(scene, steps, state_dir):
    import openmm
    _, system, factory, _ = MAKERS[scene]()
    with open(os.path.join(state_dir, STATE_OF.get(scene, scene) + ".state.xml")) as f:
        state = openmm.XmlSerializer.deserialize(f.read())
    integrator = factory()
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
    context.setState(state)
    integrator.step(1)
    integrator.step(steps)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=os.path.join(_config.SOURCE_DIR, "results", "bench"))
    parser.add_argument("--fresh", action="store_true", help="save the start states again")
    parser.add_argument("--scenes", nargs="+", choices=sorted(SCENES), default=sorted(SCENES))
    parser.add_argument("--child", nargs=2, metavar=("SCENE", "STEPS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    state_dir = os.path.join(args.out, "engine_step_instructions")
    if args.child:
        child(args.child[0], int(args.child[1]), state_dir)
        return
    valgrind = require_valgrind(parser)
    os.makedirs(state_dir, exist_ok=True)
    import openmm
    results = {}
    for scene in args.scenes:
        state_file = os.path.join(state_dir, STATE_OF.get(scene, scene) + ".state.xml")
        name, _, _, start = MAKERS[scene]()
        if args.fresh or not os.path.exists(state_file):
            print("%s: saving a start state" % scene, file=sys.stderr, flush=True)
            with open(state_file, "w") as f:
                f.write(openmm.XmlSerializer.serialize(start()))
        steps = SCENES[scene]
        print("%s: callgrind, %d and %d steps of %s" % (scene, steps[0], steps[1], name), file=sys.stderr, flush=True)
        jobs = []
        for n in steps:
            out_file = os.path.join(state_dir, "callgrind.%s.%d" % (scene, n))
            command = [valgrind, "--tool=callgrind", "--callgrind-out-file=" + out_file, sys.executable,
                       os.path.abspath(__file__), "--out", args.out, "--child", scene, str(n)]
            jobs.append((n, subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)))
        for n, job in jobs:
            _, errors = job.communicate()
            if job.returncode != 0:
                sys.exit("callgrind run failed: %s, %d steps\n%s" % (scene, n, errors[-2000:]))
        functions = per_step(*(os.path.join(state_dir, "callgrind.%s.%d" % (scene, n)) for n in steps), steps)
        engine = {f: c for f, c in functions.items() if "libOpenMMFlavors" in f}
        frozen = {f: c for f, c in engine.items() if any(part in f for part in FROZEN_STAGE)}
        results[scene] = {"integrator": name, "steps": steps, "total_per_step": sum(functions.values()),
                          "step_fs": STEP_FS[scene], "total_per_ps": sum(functions.values()) * 1000 / STEP_FS[scene],
                          "engine_per_step": sum(engine.values()), "frozen_stage_per_step": sum(frozen.values()),
                          "engine_top_functions": [{"function": f[:200], "per_step": c} for f, c in
                                                   sorted(engine.items(), key=lambda x: -x[1])[:20]],
                          "frozen_stage_functions": [{"function": f[:200], "per_step": c} for f, c in
                                                     sorted(frozen.items(), key=lambda x: -x[1])]}
        print("%-17s %-58s total %8.2fM per step (%8.1fG per ps), engine %7.3fM, frozen stage %7.3fM" % (
            scene, name, results[scene]["total_per_step"] / 1e6, results[scene]["total_per_ps"] / 1e9,
            results[scene]["engine_per_step"] / 1e6, results[scene]["frozen_stage_per_step"] / 1e6))
    with open(os.path.join(args.out, "engine_step_instructions.json"), "w") as f:
        json.dump({"benchmark": "engine_step_instructions", "platform": "CPU, 1 thread", "scenes": results}, f,
                  indent=1)
    print("wrote %s/engine_step_instructions.json" % args.out, file=sys.stderr)


if __name__ == "__main__":
    main()

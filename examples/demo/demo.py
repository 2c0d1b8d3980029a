"""The molecular wins, each beside the OpenMM integrator a practitioner would pick, in short runs of the scenes' own
code (examples/drude_water, examples/flexible_water): the speed ratio and a few observables of this run, then the
numbers of the scenes' full runs, with the commands that measure them, read from docs/scene_results.json (the file
README.md's table is checked against), and those of the Drude peptide and villin.  `make demo` runs it before the FPU
scene.

A run this short measures speed (roughly: ±30 % on a loaded machine) and shows that the observables are in place; it
cannot show that they agree within error bars: the full runs in the scenes' READMEs do that.

    PYTHONPATH=build/python .venv/bin/python examples/demo/demo.py [--production PS] [--only drude|water] [--quick]
"""
import argparse
import importlib.util
import json
import math
import os
import shutil
import textwrap
import time

import numpy as np
import openmm as mm
import openmm.unit as unit
from flavorbench.runners import time_batches

EXAMPLES = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The scenes' headline numbers, the one source of every full-run number printed here and of the README's table.
SCENE_RESULTS = os.path.join(os.path.dirname(EXAMPLES), "docs", "scene_results.json")
# Speed: rounds in which each peer steps for about this many seconds in turn, and how many rounds (quick, full).
TIMING = {False: (0.5, 5), True: (0.02, 2)}
TIMING_NOTE = ("Observables: means over %g ps of each peer, no error bars. Speed: medians over %d interleaved rounds;\n"
               "it moves with the machine's load, so quote the full runs' ratios below. (%.0f s)")


def scene(name):
    """The module of examples/<name>/<name>.py."""
    spec = importlib.util.spec_from_file_location(name + "_scene", os.path.join(EXAMPLES, name, name + ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def interleaved_speed(peers, seconds, rounds):
    """ns/day of each peer and its ratio to the first peer's: medians over `rounds` rounds in which each peer in turn
    steps for about `seconds` (flavorbench.runners.time_batches), so that a change of the machine's load hits all
    alike.  peers: {label: (context, integrator, step in fs)}."""
    try:
        timed = time_batches({label: (c, i) for label, (c, i, _) in peers.items()}, seconds, rounds)
    except mm.OpenMMException as error:  # a peer blew up: no speeds
        print("interleaved timing failed:", error)
        return {label: (math.nan, math.nan) for label in peers}
    ns_per_day = {label: np.array([step_fs * 86400 / us for us in timed[label]["all"]])
                  for label, (_, _, step_fs) in peers.items()}
    first = ns_per_day[next(iter(peers))]
    return {label: (float(np.median(v)), float(np.median(v / first))) for label, v in ns_per_day.items()}


def full_runs(name):
    """The full runs' numbers of scene `name` from docs/scene_results.json, as lines to print, wrapped to the
    terminal's width."""
    with open(SCENE_RESULTS, encoding="utf-8") as f:
        scene_result = json.load(f)["scenes"][name]
    speed, accuracy, gpu = scene_result["speed"], scene_result["accuracy"], scene_result["gpu"]
    width = min(shutil.get_terminal_size((100, 24)).columns, 120)
    entries = [("", "Full runs (%s; docs/scene_results.json): %s, %s" % (
                   scene_result["scene_readme"], scene_result["system"], scene_result["verdict"])),
               ("  ", "recipe: %s %s" % (scene_result["integrator"], scene_result["recipe"])),
               ("  ", "speed: %s%s %s (%s, %d threads; %s)" % ("about " if speed.get("approximate") else "",
                                                            speed["text"], speed["peer"], speed["platform"],
                                                            speed["threads"], speed["how"])),
               ("    ", "measured by %s" % speed["command"]),
               ("  ", "accuracy: %d runs against %s: %s" % (accuracy["runs"], accuracy["reference"],
                                                            accuracy["summary"])),
               ("    ", "measured by %s" % accuracy["command"]),
               ("  ", "where it loses: %s" % scene_result["loses"]),
               ("  ", "on a GPU: " + ("%s %s (%s)" % (gpu["text"], gpu["peer"], gpu["platform"]) if gpu.get("measured")
                                      else "unmeasured (%s)" % gpu["note"]))]
    return "\n".join(textwrap.fill(text, width, initial_indent=indent, subsequent_indent=indent + "    ",
                                    break_on_hyphens=False) for indent, text in entries)


def print_table(columns, rows):
    widths = [max(len(str(c)), *(len(str(r[i])) for r in rows)) for i, c in enumerate(columns)]
    for row in [columns] + rows:
        print("  " + "  ".join(str(v).rjust(w) if i else str(v).ljust(w) for i, (v, w) in enumerate(zip(row, widths))))


def drude_water(production_ps, quick):
    dw = scene("drude_water")
    print("\n== 1. Polarizable water (SWM4-NDP, %d molecules, PME, rigid, CPU 2 threads; examples/drude_water) ==" %
          (125 if quick else 256))
    print("StochasticImpulseIntegrator Warped, Middle placement, H = 2.5 fs, against DrudeLangevinIntegrator 1 fs "
          "(both: 300 K at 5/ps, Drudes 1 K at 20/ps)")
    begin = time.perf_counter()
    system, _, positions, box = dw.build_water(125 if quick else 256)
    analysis = dw.Analysis(system)
    scf = dw.SelfConsistent(system, analysis)
    # Minimized, then 0.5 ps of DrudeLangevin at 1 fs.
    state = dw.equilibrated_state(system, positions, 1.0, 20 if quick else 500, 1)
    settings = dict(burn_ps=0.01 if quick else 0.1, production_ps=production_ps, samples=10, blocks=2, scf_frames=2)
    edges = np.linspace(0.2, min(0.8, 0.5 * box), 61)
    peers = [("DrudeLangevin", 1.0), ("WarpedMiddle", 2.5)]
    runs = [dw.run_one(system, state, analysis, scf, kind, step_fs, settings, edges, 10 + i)
            for i, (kind, step_fs) in enumerate(peers)]
    contexts = {}
    for kind, step_fs in peers:
        integrator = dw.make_integrator(kind, step_fs, 20)
        context = mm.Context(system, integrator, mm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
        context.setState(state)
        contexts[kind] = (context, integrator, step_fs)
    speed = interleaved_speed(contexts, *TIMING[quick])
    print_table(["this run", "ns/day", "x peer", "T_COM (K)", "T_Drude (K)", "dipole (D)", "PE/molecule (kJ/mol)",
                 "induced/SCF"],
                [[("DrudeLangevin" if r["integrator"] == "DrudeLangevin" else "SIM Warped Middle") +
                  " %g fs" % r["step_fs"], "%.1f" % speed[r["integrator"]][0], "%.2f" % speed[r["integrator"]][1],
                  "%.1f" % r["t_com"][0], "%.3f" % r["t_drude"][0], "%.3f" % r["dipole"][0],
                  "%.2f" % r["pe_per_molecule"][0], "%.4f" % r["induced_ratio"][0]] for r in runs])
    print(TIMING_NOTE % (production_ps, TIMING[quick][1], time.perf_counter() - begin))
    print(full_runs("drude_water"))


def flexible_water(production_ps, quick):
    fw = scene("flexible_water")
    print("\n== 2. Flexible water (TIP3P, %d molecules, PME, CPU 2 threads; examples/flexible_water) ==" %
          (216 if quick else 501))
    print("FlavorIntegrator ArtificialProjected, O-H bonds and H-O-H angles frozen, Middle placement, delta = 6 fs, "
          "tau = 0.5 fs,\nagainst LangevinMiddleIntegrator on the same flexible water at 2 fs, the longest step "
          "within the error bars (300 K, 1/ps)")
    begin = time.perf_counter()
    forcefield, modeller = fw.build_box(216 if quick else 501)
    # The minimized box, started at 300 K, gives half its kinetic energy to the potential: 0.5 ps at 10/ps (rather
    # than the scene's 3 ps at 1/ps) brings it back to 300 K.
    start = fw.common_start(forcefield, modeller, 0.01 if quick else 0.5, 2, 20 if quick else 200, friction=10.0)
    candidates = {name: (rigid, factory) for name, rigid, factory in
                  fw.peers([("ArtificialProjected", 6.0, 0.5, True, True)])}
    chosen = [("LangevinMiddle flexible 2 fs", False,
               lambda: mm.LangevinMiddleIntegrator(fw.TEMPERATURE, fw.FRICTION, 2e-3)),
              ("FLAVOR delta=6 fs tau=0.5 fs",)
              + candidates["FLAVOR ArtificialProjected +angles Middle δ=6 fs τ=0.5 fs"]]
    records = [fw.run_peer(name, rigid, factory, forcefield, modeller.topology, start, 0.01 if quick else 0.1,
                           production_ps, 10, 2)
               for name, rigid, factory in chosen]
    contexts = {}
    for name, _, factory in chosen:
        integrator = factory()
        context = mm.Context(fw.make_system(forcefield, modeller.topology, False), integrator,
                             mm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
        context.setPositions(start)
        context.setVelocitiesToTemperature(fw.TEMPERATURE * unit.kelvin, 11)
        contexts[name] = (context, integrator, integrator.getStepSize().value_in_unit(unit.femtosecond))
    speed = interleaved_speed(contexts, *TIMING[quick])
    print_table(["this run", "ns/day", "x peer", "O-H (nm)", "O-H sd (nm)", "H-O-H (deg)", "PE/molecule (kJ/mol)",
                 "T_O (K)", "T_H (K)"],
                [[r["name"], "%.1f" % speed[r["name"]][0], "%.2f" % speed[r["name"]][1], "%.5f" % r["oh_mean"],
                  "%.5f" % r["oh_sd"], "%.2f" % r["angle_mean"], "%.2f" % r["pe_per_molecule"], "%.0f" % r["T_O"],
                  "%.0f" % r["T_H"]] if r["stable"] else [r["name"], "failed: " + r["error"]] + [""] * 7
                 for r in records])
    print(TIMING_NOTE % (production_ps, TIMING[quick][1], time.perf_counter() - begin))
    print(full_runs("flexible_water"))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--production", type=float, default=1.0, help="ps each peer runs after its burn-in (default 1)")
    parser.add_argument("--only", choices=["drude", "water"], help="one of the two scenes")
    parser.add_argument("--quick", action="store_true", help="smaller boxes, a few femtoseconds each (smoke test)")
    args = parser.parse_args()
    production = 0.02 if args.quick else args.production
    if args.only in (None, "drude"):
        drude_water(production, args.quick)
    if args.only in (None, "water"):
        flexible_water(production, args.quick)
    if args.only is None:
        print("\n== 3. Not run here: the Drude peptide (a win; examples/scripts/drude_peptide.py) and villin (not a "
              "win; examples/scripts/protein.py) ==")
        print(full_runs("drude_peptide"))
        print(full_runs("villin"))


if __name__ == "__main__":
    main()

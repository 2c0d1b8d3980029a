#!/usr/bin/env python3
"""Speed on OpenMM's GPU platforms (--platform CUDA or OpenCL): what the plugin's GPU backend runs (the FLAVOR, the
SIM's splittings, the SIM on rigid Drude water) beside OpenMM's own integrators on the same platform, in the same run,
timed in interleaved batches (flavorbench.runners.time_batches: every peer steps one batch in turn, so a change of the
machine's load hits them alike).  Each batch ends with a download of the velocities, so that the platform's queue has
drained before the clock stops.

Scenes (each in every precision of --precision: mixed and double by default; OpenMM 7.7's own default there is single):
  drude_water     SWM4-NDP polarizable water (rigid, PME; examples/drude_water): DrudeLangevin 1 fs against the
                  scene's SIM (Warped splitting, Middle placement, 2.5 fs), then both with the 0.02-nm hard wall
                  (ratios against the first peer: divide the two wall rows for SIM against DrudeLangevin with the
                  wall).  The SIM's constraint solves (SETTLE, each oxygen core's constraint impulses reaching its
                  Drude particle through the pair's flow) and its wall run on the device.
  flexible_water  flexible TIP3P water (PME; examples/flexible_water): LangevinMiddle flexible 0.5, 1 and 2 fs against
                  the nonintrusive FLAVOR with the O-H bonds and the H-O-H angles stiff (Verlet scheme, delta = 2 fs,
                  tau = 0.5 fs), and the scene's artificial FLAVOR (ArtificialProjected, bonds and angles frozen,
                  Middle, tau = 0.5 fs) at delta = 4 and 6 fs, its frozen stage on the device.
  villin          villin in water (examples/villin; amber14, PME, HBonds, rigid water): LangevinMiddle 2 fs and 4 fs with
                  hydrogen mass repartitioning (1.5 amu) against the scene's FLAVOR recipe (ArtificialProjected, bonds
                  and non-planar angles frozen, Middle, delta = 2.5 fs, tau = 1 fs) and the FLAVOR with HMR 3 amu at
                  delta = 5 fs; the frozen stage (the protein's coupled distances, the rigid water) on the host.
  drude_protein   alanine dipeptide in Drude-2019 with 250 SWM4-NDP molecules (examples/drude_protein: anisotropic and
                  Thole-screened Drude particles, lone pairs, X-H constraints on cores with Drude particles):
                  DrudeLangevin 1 fs with the 0.02-nm hard wall (what a practitioner runs) against the scene's SIM
                  (Warped, Middle, the same wall) at 2 fs and, with the phase limit 1.77 and the friction scaled, at
                  2.5 and 3 fs, on the System after separateDrudeSprings.  On OpenCL DrudeLangevin runs OpenMM's own
                  kernels, not the Reference code it runs on the CPU platform: the wall-clock comparison the scene's
                  instruction counts stand in for.
  drude_villin    villin in Drude-2019 water (OpenMM's villin box through Modeller.addExtraParticles: 14,789 particles,
                  289 Drude particles in the protein, 8,576 constraints), the peers of drude_protein
                  with the SIM's phase held at 1.4 from 2 fs on (its aromatic rings' coupling; VILLIN_MAX_PHASE).
                  Its start is made on the GPU device itself (minimized, then DrudeLangevin 0.5 fs behind the wall
                  for 2 ps): on the CPU platform its Reference Drude code takes about a second a step.  Meant for a
                  GPU; on PoCL only --quick is practical.
  fpu             FPU chains (FLAVORS paper eq. 6.7, omega = 50, reduced units read by OpenMM as ps), 200 copies:
                  the SIM (Strang, no thermostat) at H = 0.01 (omega H = 0.5) against OpenMM's VerletIntegrator at
                  h = 0.002 (omega h = 0.1) and the same SIM at h = 0.002.  Timing only: Strang is accurate at
                  small omega H (benchmarks/sim_work_precision.py measures accuracy on Reference).

The start states are made on the CPU platform (minimization and a short equilibration), then every peer starts from
them; with --states DIR they are kept there (XML, made on first use) and read back by later runs, on this or another
machine, so that a run on a borrowed GPU spends no time equilibrating.  With PoCL (a CPU OpenCL driver) the times are a CPU's: only the ratios between peers of one run mean anything.

    PYTHONPATH=build/python .venv/bin/python benchmarks/gpu_benchmark.py [--platform CUDA|OpenCL] [--quick] [--out DIR]
        [--precision mixed double] [--scenes drude_water flexible_water villin drude_protein drude_villin fpu]
        [--target S] [--repeats N] [--flexible-sizes N ...] [--drude-sizes N ...]
        [--states DIR] [--no-chart] [--replot JSON]

$FLAVORS_BENCH_QUICK=1 acts as --quick; $FLAVORS_OPENCL_PLATFORM_INDEX and $FLAVORS_OPENCL_DEVICE_INDEX pick the OpenCL
device (OpenMM's OpenCLPlatformIndex and DeviceIndex; by default OpenMM chooses), $FLAVORS_CUDA_DEVICE_INDEX the CUDA
device.  Progress goes to stderr; the table to stdout; DIR/gpu_benchmark_<platform>.json (every batch) and
DIR/gpu_benchmark_<platform>.png (ns/day bars per peer).  --no-chart
writes the JSON alone (for a machine without matplotlib); --replot JSON draws that run's chart into --out.
"""
import os
import sys
import textwrap
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.join(HERE, "..", "examples", scene)
                for scene in ("drude_water", "flexible_water", "villin", "drude_ions", "drude_protein")]

import numpy as np  # noqa: E402
import openmm as mm  # noqa: E402
import openmm.app as app  # noqa: E402
import openmm.unit as unit  # noqa: E402

import openmmflavors  # noqa: E402
from flavorbench import reporting, runners  # noqa: E402
from flavorbench.runners import time_batches  # noqa: E402
from flavorbench.systems import chain_positions, fpu_system  # noqa: E402

import drude_ions  # noqa: E402
import drude_protein  # noqa: E402
import drude_water  # noqa: E402
import flexible_water  # noqa: E402
import villin  # noqa: E402

SCENES = ("drude_water", "flexible_water", "villin", "drude_protein", "drude_villin", "fpu")
DRUDE_WALL_NM = 0.02  # CHARMM's hard wall, on every peer of the Drude-2019 scenes
# Villin's phenylalanine and tryptophan rings stiffen its Drude modes by up to 1.21 times their springs through the
# Thole-screened coupling, soft in the split (examples/drude_protein/drude_coupling.py --system villin), so Warped is
# stable there only while (1 + 1.21) sin^2(phase/2) < 1, phase < 1.47; plain Warped has 1.77 at 2 fs and holds only to
# about 1.57 fs.  The SIM peers of drude_villin hold the phase at 1.4 from 2 fs on.
VILLIN_MAX_PHASE = 1.4
# OpenMM picks the device itself unless these name one (benchmarks/device_check.sh sets OpenCL's to the GPU's).
DEVICE_VARIABLES = {"OpenCL": (("OpenCLPlatformIndex", "FLAVORS_OPENCL_PLATFORM_INDEX"),
                               ("DeviceIndex", "FLAVORS_OPENCL_DEVICE_INDEX")),
                    "CUDA": (("DeviceIndex", "FLAVORS_CUDA_DEVICE_INDEX"),)}
DEVICE_PROPERTIES = {}  # the chosen platform's, set by main()
PLATFORM_NAME = "OpenCL"  # set by main()
FPU_OMEGA, FPU_M = 50.0, 3


def log(message):
    print(message, file=sys.stderr, flush=True)


class Drained:
    """integrator.step(n), then a download of the velocities: a GPU platform enqueues a step's kernels and returns, so
    a batch's time is complete only once the queue has drained."""

    def __init__(self, context, integrator):
        self.context, self.integrator = context, integrator

    def step(self, n):
        self.integrator.step(n)
        self.context.getState(getVelocities=True)


def gpu_platform():
    try:
        return mm.Platform.getPlatformByName(PLATFORM_NAME)
    except Exception:
        names = [mm.Platform.getPlatform(i).getName() for i in range(mm.Platform.getNumPlatforms())]
        remedy = ("an NVIDIA GPU, its driver and OpenMM's CUDA add-on (openmm-cuda-13)" if PLATFORM_NAME == "CUDA" else
                  "an OpenCL driver (an ICD in /etc/OpenCL/vendors, e.g. NVIDIA's or pocl-opencl-icd)")
        sys.exit(f"gpu_benchmark: OpenMM has no {PLATFORM_NAME} platform (platforms: {', '.join(names)}); it needs "
                 f"{remedy}")


def short_reason(error):
    """Why a peer is not timed, in a few words for the table and the chart (the JSON keeps OpenMM's whole message)."""
    text = str(error)
    if "not quadratic" in text:
        return "rejected: stiff forces not quadratic at this precision"
    if "not yet" in text or "not supported" in text or "unsupported" in text:
        return f"not available on {PLATFORM_NAME} yet"
    return "failed: " + text[:40]


def device_of(platform, context):
    keys = ("DeviceName", "OpenCLPlatformName", "Precision", "DeviceIndex", "OpenCLPlatformIndex")
    return {key: platform.getPropertyValue(context, key) for key in keys if key in platform.getPropertyNames()}


def stored_start(states, key, make):
    """make() -> an openmm.State (positions, velocities where it has them), kept as states/key.xml when states names a
    folder: read from there when present, made and written otherwise."""
    if not states:
        return make()
    path = os.path.join(states, key + ".xml")
    if os.path.exists(path):
        log(f"  start state read from {path}")
        with open(path) as f:
            return mm.XmlSerializer.deserialize(f.read())
    state = make()
    os.makedirs(states, exist_ok=True)
    with open(path, "w") as f:
        f.write(mm.XmlSerializer.serialize(state))
    log(f"  start state written to {path}")
    return state


def positions_state(system, positions):
    """A State holding only `positions` (a Context on the Reference platform makes it)."""
    context = mm.Context(system, mm.VerletIntegrator(0.001), mm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions)
    return context.getState(getPositions=True)


def thermal_start(positions, temperature):
    """start(context) for a scene: the positions, velocities drawn at temperature (K) with the seed every peer shares."""
    def start(context):
        context.setPositions(positions)
        context.setVelocitiesToTemperature(temperature * unit.kelvin, 7)
    return start


# ----------------------------------------------------------------------------------------------------------------------
# Scenes: each returns (description, start, peers); a peer is (name, step in fs, system, integrator factory, note)
# and start(context) puts a new Context at the scene's start state.

def drude_scene(quick, states, molecules=None):
    molecules = molecules or (64 if quick else 256)
    log(f"drude_water: {molecules} SWM4-NDP molecules, minimizing and equilibrating on the CPU platform")
    system, _, positions, _ = drude_water.build_water(molecules)
    steps = 50 if quick else 1000
    state = stored_start(states, f"drude_water_{molecules}_{steps}",
                         lambda: drude_water.equilibrated_state(system, positions, 1.0, steps, 1))
    def sim_with_wall():
        integrator = drude_water.make_integrator("WarpedMiddle", 2.5, 7)
        integrator.setMaxDrudeDistance(drude_water.WALL_NM * unit.nanometer)
        return integrator

    wall = f"{drude_water.WALL_NM:g}-nm wall"
    peers = [("DrudeLangevin 1 fs", 1.0, system, lambda: drude_water.make_integrator("DrudeLangevin", 1.0, 7), ""),
             ("SIM Warped Middle 2.5 fs", 2.5, system, lambda: drude_water.make_integrator("WarpedMiddle", 2.5, 7),
              "the scene's SIM peer"),
             (f"DrudeLangevin 1 fs, {wall}", 1.0, system,
              lambda: drude_water.make_integrator("DrudeLangevinWall", 1.0, 7), ""),
             (f"SIM Warped Middle 2.5 fs, {wall}", 2.5, system, sim_with_wall, "against DrudeLangevin with the wall")]
    description = f"{molecules} SWM4-NDP molecules ({system.getNumParticles()} particles), rigid, PME"
    return description, lambda context: context.setState(state), peers


def flexible_scene(quick, states, molecules=None):
    molecules = molecules or (216 if quick else 501)
    log(f"flexible_water: {molecules} TIP3P molecules, minimizing and equilibrating on the CPU platform")
    forcefield, modeller = flexible_water.build_box(molecules)
    system = flexible_water.make_system(forcefield, modeller.topology, False)
    positions = stored_start(states, f"flexible_water_{molecules}_{'quick' if quick else 'full'}", lambda: positions_state(
        system, flexible_water.common_start(forcefield, modeller, 0.05 if quick else 1.0, 2, 20 if quick else 200)
    )).getPositions()
    stiff = {flexible_water.BOND_GROUP, flexible_water.ANGLE_GROUP}

    def langevin_middle(step_fs):
        return lambda: mm.LangevinMiddleIntegrator(flexible_water.TEMPERATURE, flexible_water.FRICTION, step_fs * 1e-3)

    def flavor(averaging):
        def factory():
            integrator = openmmflavors.FlavorIntegrator(2.0 * unit.femtosecond, 0.5 * unit.femtosecond, stiff)
            integrator.setAveraging(averaging)
            integrator.setTemperature(flexible_water.TEMPERATURE * unit.kelvin)
            integrator.setFriction(flexible_water.FRICTION / unit.picosecond)
            integrator.setRandomNumberSeed(1234)
            return integrator
        return factory

    FI = openmmflavors.FlavorIntegrator
    peers = [(f"LangevinMiddle flexible {h:g} fs", h, system, langevin_middle(h), "") for h in (0.5, 1.0, 2.0)]
    peers.append(("FLAVOR Nonintrusive +angles δ=2 fs τ=0.5 fs", 2.0, system, flavor(FI.Nonintrusive),
                  "O-H bonds and H-O-H angles stiff"))
    for delta in (4.0, 6.0):
        name, _, factory, _ = flexible_water.flavor_peer("ArtificialProjected", delta, 0.5, True, True)
        peers.append((name, delta, system, lambda factory=factory: factory(1234),
                      "the scene's artificial FLAVOR (frozen stage on the device)"))

    description = f"{molecules} flexible TIP3P molecules ({3 * molecules} atoms), PME, 300 K, friction 1/ps"
    return description, thermal_start(positions, flexible_water.TEMPERATURE), peers


def villin_scene(quick, states):
    log("villin: minimizing and equilibrating on the CPU platform")
    forcefield = app.ForceField("amber14-all.xml", "amber14/tip3p.xml")
    pdb = app.PDBFile(villin.PDB)
    systems = {}

    def system_for(options):
        key = (options["hydrogen_mass"], options["water_hydrogen_mass"])
        if key not in systems:
            systems[key] = villin.make_system(forcefield, pdb.topology, **options)
        return systems[key]

    plain = system_for({"hydrogen_mass": None, "water_hydrogen_mass": False})

    def equilibrate():
        integrator = mm.LangevinMiddleIntegrator(villin.TEMPERATURE, villin.FRICTION, 0.002)
        context = mm.Context(plain, integrator, mm.Platform.getPlatformByName("CPU"))
        context.setPositions(pdb.positions)
        mm.LocalEnergyMinimizer.minimize(context, 10, 50 if quick else 200)
        context.setVelocitiesToTemperature(villin.TEMPERATURE * unit.kelvin, 7)
        integrator.step(10 if quick else 500)
        return context.getState(getPositions=True)

    positions = stored_start(states, f"villin_{'quick' if quick else 'full'}", equilibrate).getPositions()
    # The scene's recipe without HMR, and with HMR 3 amu at delta = 5 fs beside OpenMM's HMR peer.
    entries = villin.peers([(2.5, 1.0, "bonds+nonplanar angles", True),
                            (5.0, 1.0, "bonds+nonplanar angles", True, 3.0)],
                           hmr_langevin=[(4.0, 1.5)], mts=False, seed=7)
    steps = {"LangevinMiddle 2 fs": 2.0, "LangevinMiddle 4 fs": 4.0}
    peers = []
    for name, factory in entries:
        step_fs = next((v for k, v in steps.items() if name.startswith(k)), None)
        if step_fs is None:
            step_fs = float(name.split("δ=")[1].split(" ")[0])
        peers.append((name, step_fs, system_for(factory.system_options), factory,
                      "frozen stage on the host" if name.startswith("FLAVOR") else ""))

    description = f"villin in TIP3P water ({plain.getNumParticles()} atoms), amber14, PME, HBonds, rigid water"
    return description, thermal_start(positions, villin.TEMPERATURE), peers


def drude_2019_peers(system, max_phase_from_2fs=0.0):
    """DrudeLangevin 1 fs with the wall on `system`, the SIM on its separated copy at 2 fs and, phase-limited with the
    friction scaled, at 2.5 and 3 fs, all behind the wall (examples/drude_protein's peers).  The phase limit is 1.77
    (plain Warped's at 2 fs), or max_phase_from_2fs from 2 fs on where given."""
    separated = mm.XmlSerializer.deserialize(mm.XmlSerializer.serialize(system))
    openmmflavors.StochasticImpulseIntegrator.separateDrudeSprings(separated, drude_ions.SPRING_GROUP)

    def factory(kind, step_fs, max_warped_phase=0.0, scaled_friction=False):
        def make():
            integrator = drude_ions.make_integrator(kind, step_fs, 7, max_warped_phase, scaled_friction)
            integrator.setMaxDrudeDistance(DRUDE_WALL_NM)
            return integrator
        return make

    peers = [("DrudeLangevin 1 fs + wall", 1.0, system, factory("DrudeLangevin", 1.0), "what a practitioner runs")]
    if max_phase_from_2fs > 0:
        peers.append((f"SIM Warped Middle 2 fs, ω̃H ≤ {max_phase_from_2fs:g} + wall", 2.0, separated,
                      factory("WarpedMiddle", 2.0, max_phase_from_2fs), ""))
    else:
        peers.append(("SIM Warped Middle 2 fs + wall", 2.0, separated, factory("WarpedMiddle", 2.0),
                      "the scene's SIM"))
    phase = max_phase_from_2fs or 1.77
    for step_fs in (2.5, 3.0):
        peers.append((f"SIM Warped Middle {step_fs:g} fs, ω̃H ≤ {phase:g}, friction scaled + wall", step_fs,
                      separated, factory("WarpedMiddle", step_fs, phase, True), ""))
    return peers


def drude_protein_scene(quick, states):
    waters, cutoff, equilibration_ps = (80, 0.55, 0.05) if quick else (250, 0.8, 1.0)
    log(f"drude_protein: alanine dipeptide in {waters} SWM4-NDP molecules, minimizing and equilibrating on the CPU "
        "platform")
    system, _, positions = drude_protein.build(waters, cutoff)
    state = stored_start(states, f"drude_protein_{waters}_{equilibration_ps:g}ps",
                         lambda: drude_ions.equilibrated(system, positions, 1, equilibration_ps))
    description = (f"alanine dipeptide (Drude-2019) in {waters} SWM4-NDP molecules ({system.getNumParticles()} "
                   f"particles), PME, hard wall {DRUDE_WALL_NM:g} nm")
    return description, lambda context: context.setState(state), drude_2019_peers(system)


def drude_villin_scene(quick, states):
    pdb = app.PDBFile(villin.PDB)
    system, _, positions = drude_ions.polar_system(app.Modeller(pdb.topology, pdb.positions), 1.0)
    iterations, steps = (100, 200) if quick else (500, 4000)
    log(f"drude_villin: villin in Drude-2019 water ({system.getNumParticles()} particles), minimizing and running "
        f"{steps} steps of DrudeLangevin 0.5 fs behind the wall on the {PLATFORM_NAME} device")

    def equilibrate():
        integrator = drude_ions.make_integrator("DrudeLangevin", 0.5, 1)
        integrator.setMaxDrudeDistance(DRUDE_WALL_NM)
        context = mm.Context(system, integrator, gpu_platform(), dict(DEVICE_PROPERTIES, Precision="mixed"))
        context.setPositions(positions)
        mm.LocalEnergyMinimizer.minimize(context, 10, iterations)
        context.setVelocitiesToTemperature(300 * unit.kelvin, 2)
        integrator.step(steps)
        return context.getState(getPositions=True, getVelocities=True)

    state = stored_start(states, f"drude_villin_{'quick' if quick else 'full'}", equilibrate)
    description = (f"villin in Drude-2019 water ({system.getNumParticles()} particles), PME, HBonds, rigid water, hard "
                   f"wall {DRUDE_WALL_NM:g} nm")
    return description, lambda context: context.setState(state), drude_2019_peers(system, VILLIN_MAX_PHASE)


def fpu_scene(quick, states):
    chains = 50 if quick else 200
    system = fpu_system(FPU_M, FPU_OMEGA, chains)
    positions = chain_positions(FPU_M, FPU_OMEGA, chains)

    # Steps in reduced time units (OpenMM reads them as ps); the peers' "fs" are 1e-3 units.
    peers = [("Verlet h=0.002", 2.0, system, lambda: mm.VerletIntegrator(0.002), "omega h = 0.1"),
             ("SIM Strang H=0.002", 2.0, system, lambda: runners.sim(0.002, "Strang"), "omega H = 0.1"),
             ("SIM Strang H=0.01", 10.0, system, lambda: runners.sim(0.01, "Strang"), "omega H = 0.5")]

    def start(context):
        context.setPositions(positions)
        context.setVelocities(np.zeros_like(positions))

    description = (f"{chains} FPU chains of {2 * FPU_M} unit masses (ω = {FPU_OMEGA:g}; reduced units, 1 unit "
                   "read as 1 ps)")
    return description, start, peers


# ----------------------------------------------------------------------------------------------------------------------

def run_scene(name, scene, platform, precisions, target, repeats):
    description, start, peers = scene
    result = {"system": description, "precisions": {}}
    for precision in precisions:
        log(f"{name}, {precision} precision: creating the Contexts (the {PLATFORM_NAME} kernels compile on first use)")
        cases, steps, records, device = {}, {}, {}, None
        for peer, step_fs, system, factory, note in peers:
            integrator = factory()
            began = time.perf_counter()
            try:
                context = mm.Context(system, integrator, platform, dict(DEVICE_PROPERTIES, Precision=precision))
                start(context)
                integrator.step(1)
            except mm.OpenMMException as error:
                records[peer] = {"available": False, "error": str(error), "reason": short_reason(error),
                                 "step_fs": step_fs, "note": note, "setup_s": time.perf_counter() - began}
                log(f"  {peer}: not timed ({records[peer]['reason']}): {error}")
                continue
            log(f"  {peer}: ready in {time.perf_counter() - began:.1f} s")
            device = device or device_of(platform, context)
            cases[peer] = (context, Drained(context, integrator))
            steps[peer] = step_fs
            records[peer] = {"available": True, "step_fs": step_fs, "note": note,
                             "setup_s": time.perf_counter() - began}
        timings = time_batches(cases, target, repeats, label=f"{name} {precision}")
        for peer, timing in timings.items():
            records[peer].update(timing)
            records[peer]["ns_per_day"] = steps[peer] * 86400 / timing["us_per_step"]
            records[peer]["ns_per_day_median"] = steps[peer] * 86400 / timing["us_per_step_median"]
        result["precisions"][precision] = {"device": device, "peers": records}
        del cases
    return result


def print_tables(data):
    for name, scene in data["scenes"].items():
        for precision, run in scene["precisions"].items():
            peers = run["peers"]
            timed = [p for p in peers.values() if p["available"]]
            base = timed[0]["ns_per_day"] if timed else float("nan")
            rows = []
            for peer, record in peers.items():
                if record["available"]:
                    rows.append([peer, record["step_fs"], record["us_per_step"], record["ns_per_day"],
                                 record["ns_per_day"] / base, ""])
                else:
                    rows.append([peer, record["step_fs"], "-", "-", "-", record["reason"]])
            reporting.table(f"{name}: {scene['system']}, {data.get('platform', 'OpenCL')} {precision} "
                            f"({(run['device'] or {}).get('DeviceName', '?')})",
                            [("peer", max(len(peer) for peer in peers), "s"), ("step fs", 8, ".3g"),
                             ("us/step", 10, ".4g"),
                             ("ns/day", 10, ".4g"), ("ratio", 7, ".3g"),
                             ("", 1, "s")], rows)


def plot(data, path):
    plt = reporting.pyplot()
    panels = [(name, precision, run) for name, scene in data["scenes"].items()
              for precision, run in scene["precisions"].items()]
    fig, axes = plt.subplots(len(panels), 1, figsize=(12, 2.6 + 1.1 * sum(len(r["peers"]) for *_, r in panels) / 2),
                             squeeze=False)
    device = next(((r["device"] or {}).get("DeviceName") for *_, r in panels if r["device"]), "?")
    platform = data.get("platform", "OpenCL")
    opencl = next(((r["device"] or {}).get("OpenCLPlatformName") for *_, r in panels if r["device"]), "")
    driver = f"{opencl}: {device}" if opencl else device
    for ax, (name, precision, run) in zip(axes[:, 0], panels):
        peers = list(run["peers"].items())
        y = np.arange(len(peers))
        values = [r["ns_per_day"] if r["available"] else 0.0 for _, r in peers]
        colors = ["tab:orange" if p.startswith(("FLAVOR", "SIM")) else "tab:blue" for p, _ in peers]
        ax.barh(y, values, color=colors)
        top = max(values) if max(values) > 0 else 1.0
        for i, (peer, record) in enumerate(peers):
            text = f"{record['ns_per_day']:.3g}" if record["available"] else record["reason"]
            ax.text(values[i] + 0.01 * top, i, text, va="center", fontsize=8,
                    color="black" if record["available"] else "tab:red")
        ax.set_yticks(y)
        ax.set_yticklabels([p for p, _ in peers], fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, 1.35 * top)
        unit_note = " (reduced time units read as ps)" if name == "fpu" else ""
        ax.set_xlabel(f"ns/day{unit_note}")
        # Left-aligned on the axes, wrapped: the long peer names push the axes to the right half of the figure.
        ax.set_title(textwrap.fill(f"{name}: {data['scenes'][name]['system']} — {precision} precision", 70),
                     fontsize=9, loc="left")
    pocl = "pocl" in opencl.lower() or "portable computing language" in opencl.lower()
    fig.suptitle(f"ns/day on OpenMM's {platform} platform ({driver}): the plugin's integrators (orange)\n"
                 "against OpenMM's own (blue) in the same run, interleaved batches, best batch.  " +
                 ("PoCL is a CPU OpenCL driver:\nits times are a CPU's, only the ratios within a panel count"
                  if pocl else "Compare ratios within a panel"), fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.5 / fig.get_figheight()))  # room for the three lines of the title
    reporting.save_figure(fig, path, 110)


def main():
    global PLATFORM_NAME
    p = reporting.parser(__doc__, "gpu", quick_help="a smoke run: small systems, short batches")
    p.add_argument("--platform", default="OpenCL", choices=["CUDA", "OpenCL"], help="OpenMM's GPU platform to run on")
    p.add_argument("--precision", nargs="+", default=["mixed", "double"], choices=["single", "mixed", "double"])
    p.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    p.add_argument("--target", type=float, default=None, help="seconds per batch (default 3, --quick 0.5)")
    p.add_argument("--repeats", type=int, default=None, help="rounds of batches (default 5, --quick 2)")
    p.add_argument("--states", default=None, metavar="DIR",
                   help="keep the scenes' start states in DIR (XML): read when there, made and written otherwise")
    p.add_argument("--make-states-only", action="store_true",
                   help="make the scenes' start states into --states and stop (benchmarks/device_prepare.sh)")
    p.add_argument("--flexible-sizes", nargs="+", type=int, default=None, metavar="N",
                   help="flexible_water at these numbers of molecules (default 501, --quick 216), e.g. 501 4000 16000")
    p.add_argument("--drude-sizes", nargs="+", type=int, default=None, metavar="N",
                   help="drude_water at these numbers of molecules (default 256, --quick 64), e.g. 256 2048 8192")
    p.add_argument("--no-chart", action="store_true", help="write the JSON only (draw it later with --replot)")
    p.add_argument("--replot", metavar="JSON", help="only draw the chart of an earlier run's JSON into --out")
    args = p.parse_args()
    if args.replot:
        reporting.replot(args.replot, args.out, f"gpu_benchmark_{args.platform.lower()}", plot)
        return
    PLATFORM_NAME = args.platform
    DEVICE_PROPERTIES.update({key: os.environ[variable] for key, variable in DEVICE_VARIABLES[PLATFORM_NAME]
                              if os.environ.get(variable)})
    if os.environ.get("FLAVORS_BENCH_QUICK", "") not in ("", "0"):
        args.quick = True
        reporting.set_smoke_run(True)
    target = args.target or (0.5 if args.quick else 3.0)
    repeats = args.repeats or (2 if args.quick else 5)
    builders = {"drude_water": drude_scene, "flexible_water": flexible_scene, "villin": villin_scene,
                "drude_protein": drude_protein_scene, "drude_villin": drude_villin_scene, "fpu": fpu_scene}
    data = {"command": " ".join(sys.argv), "platform": PLATFORM_NAME, "quick": args.quick, "batch_target_s": target,
            "repeats": repeats,
            "openmm_version": mm.Platform.getOpenMMVersion(), "scenes": {}}
    sizes = {"flexible_water": args.flexible_sizes, "drude_water": args.drude_sizes}
    # Each scene at each of its sizes: (key in the JSON, scene, molecules or None for the scene's own).
    runs = [(f"{name}_{n}" if sizes.get(name) else name, name, n) for name in args.scenes
            for n in (sizes.get(name) or [None])]

    def build(name, molecules):
        return builders[name](args.quick, args.states, molecules) if molecules else builders[name](args.quick,
                                                                                                    args.states)
    if args.make_states_only:
        if not args.states:
            p.error("--make-states-only needs --states DIR")
        for _, name, molecules in runs:
            build(name, molecules)
        return
    platform = gpu_platform()
    for key, name, molecules in runs:
        data["scenes"][key] = run_scene(key, build(name, molecules), platform, args.precision, target, repeats)
    print_tables(data)
    stem = f"gpu_benchmark_{PLATFORM_NAME.lower()}"
    if args.no_chart:
        reporting.write_json(os.path.join(args.out, f"{stem}.json"), data, strict=False)
        print(f"\nwrote {os.path.join(args.out, stem + '.json')} (no chart: --no-chart)")
    else:
        reporting.save_outputs(args.out, stem, data, lambda path: plot(data, path))


if __name__ == "__main__":
    main()

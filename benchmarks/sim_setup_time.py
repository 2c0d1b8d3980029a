"""Wall time of StochasticImpulseIntegrator's stiff-group measurement on a water box, on Reference and CPU.

(a) Rejection: a flexible TIP3P box (501 waters, 1,503 atoms, PME, openmm.app's tip3p.xml with rigidWater=False)
    whose HarmonicBondForce (O-H bonds, rest length 0.09572 nm) alone is the stiff group.  The bonds are not
    quadratic, so the first getStiffModeFrequencies() raises; the time from that call to the exception.
(b) Set-up: the same box with every bond given rest length 0, a valid quadratic stiff group of 1,503 particles in
    501 components; the time of the first getStiffModeFrequencies() (probing, checks, modes and propagators).

Each is the best of --repeats fresh Contexts.  Prints a table and writes JSON (default results/sim_setup_time.json).

    PYTHONPATH=build/python .venv/bin/python benchmarks/sim_setup_time.py [--repeats N] [--out FILE]
"""
import argparse
import json
import os
import platform as host
import time

import openmm
from openmm import app, unit

import openmmflavors

WATERS = 501
STIFF_GROUP = 1


def water_box():
    """A flexible TIP3P box of WATERS waters with PME; its HarmonicBondForce in STIFF_GROUP, the rest in 0."""
    forcefield = app.ForceField("tip3p.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(forcefield, model="tip3p", numAdded=WATERS)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=0.7 * unit.nanometer,
                                     rigidWater=False, constraints=None)
    for force in system.getForces():
        force.setForceGroup(STIFF_GROUP if isinstance(force, openmm.HarmonicBondForce) else 0)
    return system, modeller.positions


def zero_length_bonds(system):
    """The same System with every HarmonicBondForce bond of rest length 0: a quadratic stiff group."""
    copy = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
    for force in copy.getForces():
        if isinstance(force, openmm.HarmonicBondForce):
            for i in range(force.getNumBonds()):
                p1, p2, _, k = force.getBondParameters(i)
                force.setBondParameters(i, p1, p2, 0.0, k)
    return copy


def measure(system, positions, platform_name, expect_rejection):
    """Seconds of the first getStiffModeFrequencies() on a fresh Context, and the message if it raised."""
    integrator = openmmflavors.StochasticImpulseIntegrator(300, 1, 0.002, {STIFF_GROUP})
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName(platform_name))
    context.setPositions(positions)
    start = time.perf_counter()
    message = None
    try:
        integrator.getStiffModeFrequencies()
    except openmm.OpenMMException as error:
        message = str(error)
    seconds = time.perf_counter() - start
    if expect_rejection != (message is not None):
        raise RuntimeError(f"{platform_name}: expected {'a rejection' if expect_rejection else 'modes'}, got "
                           f"{message!r}")
    del context
    return seconds, message


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=os.path.join("results", "sim_setup_time.json"))
    args = parser.parse_args()

    system, positions = water_box()
    quadratic = zero_length_bonds(system)
    results = {"particles": system.getNumParticles(), "waters": WATERS, "repeats": args.repeats,
               "host": host.node(), "platforms": {}}
    print(f"{system.getNumParticles()} particles; best of {args.repeats} fresh Contexts")
    print(f"{'platform':10s} {'rejection (s)':>14s} {'set-up (s)':>11s}")
    for platform_name in ("Reference", "CPU"):
        rejection = [measure(system, positions, platform_name, True) for _ in range(args.repeats)]
        setup = [measure(quadratic, positions, platform_name, False)[0] for _ in range(args.repeats)]
        entry = {"rejection_s": min(t for t, _ in rejection), "rejection_all_s": [t for t, _ in rejection],
                 "setup_s": min(setup), "setup_all_s": setup, "rejection_message": rejection[0][1]}
        results["platforms"][platform_name] = entry
        print(f"{platform_name:10s} {entry['rejection_s']:14.4f} {entry['setup_s']:11.4f}")
    print("rejection message:", results["platforms"]["Reference"]["rejection_message"])
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as out:
        json.dump(results, out, indent=2)
    print("wrote", args.out)


if __name__ == "__main__":
    main()

"""Memory kept by OpenMM 7.7 for each Context whose creation the integrator rejects.

OpenMM 7.7's Context constructor does not free its ContextImpl when Integrator::initialize throws, so every rejected
Context leaves its ContextImpl, platform data and force implementations behind.  This script creates --count
rejected Contexts (a FlavorIntegrator on a System without soft forces) on each platform and prints the growth of the
resident set size per rejection, after a warm-up of the same size.

    PYTHONPATH=build/python .venv/bin/python benchmarks/rejected_context_leak.py [--count N] [--particles N]
"""
import argparse
import os

import openmm

import openmmflavors


def resident_bytes():
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def rejected_system(particles):
    system = openmm.System()
    bond = openmm.HarmonicBondForce()
    for i in range(particles):
        system.addParticle(1.0)
        if i > 0:
            bond.addBond(i - 1, i, 0.0, 100.0)
    system.addForce(bond)  # group 0, the only group: no soft force
    return system


def rejections(system, platform, count):
    for _ in range(count):
        integrator = openmmflavors.FlavorIntegrator(0.01, 0.001, {0})
        try:
            openmm.Context(system, integrator, platform)
        except openmm.OpenMMException:
            pass
        else:
            raise RuntimeError("the Context was not rejected")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--count", type=int, default=2000)
    parser.add_argument("--particles", type=int, default=2)
    args = parser.parse_args()
    system = rejected_system(args.particles)
    for name in ("Reference", "CPU"):
        platform = openmm.Platform.getPlatformByName(name)
        rejections(system, platform, args.count)
        before = resident_bytes()
        rejections(system, platform, args.count)
        growth = resident_bytes() - before
        print(f"{name:10s} {args.particles} particles: {growth / args.count:8.0f} bytes per rejected Context "
              f"({args.count} rejections)")


if __name__ == "__main__":
    main()

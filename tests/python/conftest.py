"""Shared systems and helpers for the openmmflavors tests.

The test system is a small Fermi-Pasta-Ulam chain: 6 unit-mass particles on the x axis, stiff harmonic springs
of rest length 0 between (0,1), (2,3), (4,5) in force group 1, and soft quartic springs r^4 between (1,2), (3,4)
plus quartic walls x^4 on particles 0 and 5 in force group 0.
"""
import importlib.util
import locale
import math
import os
import subprocess
import sys

import numpy as np
import openmm
import openmm.unit as unit
import pytest

import openmmflavors  # noqa: F401  (loads the plugin kernels and patches XmlSerializer)
from openmmflavors import FlavorIntegrator



def _has_platform(name):
    return any(openmm.Platform.getPlatform(i).getName() == name for i in range(openmm.Platform.getNumPlatforms()))


# The GPU platforms where OpenMM has them (OpenCL: an OpenCL driver such as PoCL; CUDA: an NVIDIA GPU, its driver and
# OpenMM's CUDA add-on), in double precision.
GPU_PLATFORMS = [name for name in ("OpenCL", "CUDA") if _has_platform(name)]
PLATFORMS = ["Reference", "CPU"] + GPU_PLATFORMS
# The GPU platforms' stiff forces are about 1e-6 relative off Reference's even in double precision (their force
# constants and bonded terms; measured on PoCL, where CUDA runs the same kernels in IEEE double arithmetic): a
# trajectory that follows an independent double-precision composition to 1e-10 on Reference and CPU follows it to about
# 4e-9 relative there.
TRAJECTORY_RTOL = {"OpenCL": 1e-7, "CUDA": 1e-7}

@pytest.fixture(autouse=True)
def _environment_locale():
    """Gives every test the environment's locale back.  OpenMM 8.6's OpenCL platform, creating a Context with PME on
    PoCL, sets the process's C locale to "C" (measured: LC_CTYPE C.UTF-8 before, C after), after which Python opens
    files and decodes subprocess output as ASCII; a later test would fail on the README's "±"."""
    yield
    locale.setlocale(locale.LC_ALL, "")


SOFT_GROUP = 0
STIFF_GROUP = 1
OMEGA = 40.0
STIFF_PAIRS = [(0, 1), (2, 3), (4, 5)]
SOFT_PAIRS = [(1, 2), (3, 4)]
WALL_PARTICLES = [0, 5]

# Generic values (no symmetry, no particle pair at the same x) so that every force term is active.
INITIAL_X = np.array([-0.55, -0.42, -0.12, 0.03, 0.36, 0.51])
INITIAL_VX = np.array([0.3, -0.2, 0.5, -0.4, 0.1, 0.25])

MESO_STEP = 0.02
MICRO_STEP = 0.002


def build_fpu_system(stiff_group=STIFF_GROUP, soft_group=SOFT_GROUP, omega=OMEGA):
    system = openmm.System()
    for _ in range(6):
        system.addParticle(1.0)
    stiff = openmm.HarmonicBondForce()
    for i, j in STIFF_PAIRS:
        stiff.addBond(i, j, 0.0, omega**2 / 2)
    stiff.setForceGroup(stiff_group)
    soft = openmm.CustomBondForce("r^4")
    for i, j in SOFT_PAIRS:
        soft.addBond(i, j, [])
    soft.setForceGroup(soft_group)
    walls = openmm.CustomExternalForce("x^4")
    for i in WALL_PARTICLES:
        walls.addParticle(i, [])
    walls.setForceGroup(soft_group)
    system.addForce(stiff)
    system.addForce(soft)
    system.addForce(walls)
    return system


def fpu_positions():
    return [openmm.Vec3(x, 0.0, 0.0) for x in INITIAL_X] * unit.nanometer


def fpu_velocities():
    return [openmm.Vec3(v, 0.0, 0.0) for v in INITIAL_VX] * (unit.nanometer / unit.picosecond)


def numpy_forces(x, which):
    """Forces along x of the FPU chain for 'stiff', 'soft' or 'all' (unit masses, so also accelerations)."""
    f = np.zeros_like(x)
    if which in ("stiff", "all"):
        k = OMEGA**2 / 2
        for i, j in STIFF_PAIRS:
            d = x[j] - x[i]
            f[i] += k * d
            f[j] -= k * d
    if which in ("soft", "all"):
        for i, j in SOFT_PAIRS:
            d = x[j] - x[i]
            f[i] += 4 * d**3
            f[j] -= 4 * d**3
        for i in WALL_PARTICLES:
            f[i] -= 4 * x[i]**3
    return f


def assert_close_relative(actual, expected, rtol=1e-10):
    scale = np.max(np.abs(expected))
    assert scale > 0
    error = np.max(np.abs(actual - expected))
    assert error <= rtol * scale, f"max deviation {error:.3e} exceeds {rtol:.0e} x {scale:.3e}"


def platform_properties(platform_name):
    # A fixed thread count keeps CPU results independent of the machine; OpenCL runs in double precision.
    return {"CPU": {"Threads": "2"}, "OpenCL": {"Precision": "double"}}.get(platform_name, {})


def make_context(system, integrator, platform_name, positions=None, velocities=None):
    platform = openmm.Platform.getPlatformByName(platform_name)
    context = openmm.Context(system, integrator, platform, platform_properties(platform_name))
    context.setPositions(fpu_positions() if positions is None else positions)
    context.setVelocities(fpu_velocities() if velocities is None else velocities)
    return context


def make_integrator(meso=MESO_STEP, micro=MICRO_STEP, groups=1 << STIFF_GROUP, scheme=None, temperature=None,
                    friction=None, seed=None, stiff_friction=None):
    integrator = FlavorIntegrator(meso, micro, groups)
    if scheme is not None:
        integrator.setScheme(scheme)
    if temperature is not None:
        integrator.setTemperature(temperature)
    if friction is not None:
        integrator.setFriction(friction)
    if seed is not None:
        integrator.setRandomNumberSeed(seed)
    if stiff_friction is not None:
        integrator.setStiffFriction(stiff_friction)
    return integrator


def state_arrays(context, forces=False):
    """Positions (nm) and velocities (nm/ps) as float64 arrays, plus forces (kJ/mol/nm) if asked for."""
    state = context.getState(getPositions=True, getVelocities=True, getForces=forces)
    pos = np.array(state.getPositions(asNumpy=True).value_in_unit(unit.nanometer), dtype=np.float64)
    vel = np.array(state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond),
                   dtype=np.float64)
    if forces:
        frc = np.array(state.getForces(asNumpy=True).value_in_unit(unit.kilojoule_per_mole / unit.nanometer),
                       dtype=np.float64)
        return pos, vel, frc
    return pos, vel


def run_trajectory(context, steps):
    """Step one mesostep at a time; return the positions and velocities after every step."""
    positions, velocities = [], []
    for _ in range(steps):
        context.getIntegrator().step(1)
        pos, vel = state_arrays(context)
        positions.append(pos)
        velocities.append(vel)
    return np.array(positions), np.array(velocities)


@pytest.fixture(params=PLATFORMS)
def platform_name(request):
    return request.param


@pytest.fixture
def fpu_system():
    return build_fpu_system()


def assert_set_state_reproduces(context, before, after):
    """Resetting positions and velocities by hand must reproduce the continuation: cached forces are invalidated."""
    context.getIntegrator().step(before)
    pos, vel = state_arrays(context)
    positions, velocities = run_trajectory(context, after)
    context.setPositions(pos * unit.nanometer)
    context.setVelocities(vel * unit.nanometer / unit.picosecond)
    positions_again, velocities_again = run_trajectory(context, after)
    np.testing.assert_array_equal(positions_again, positions)
    np.testing.assert_array_equal(velocities_again, velocities)


def assert_continuation_depends_on_random_state(context, before, after):
    """Restoring only positions and velocities must NOT reproduce a Langevin continuation; otherwise checkpoint
    tests would not show that the random state is restored."""
    context.getIntegrator().step(before)
    state = context.getState(getPositions=True, getVelocities=True)
    positions, _ = run_trajectory(context, after)
    context.setState(state)
    positions_again, _ = run_trajectory(context, after)
    assert np.max(np.abs(positions_again[-1] - positions[-1])) > 1e-4


def assert_cli_rejects(script, out, extra, message):
    """The script run with --quick --out OUT and the extra arguments exits with an error whose stderr says message."""
    result = run_quick(script, out, extra=extra)
    assert result.returncode != 0
    assert message in result.stderr, result.stderr[-2000:]


def run_quick(script, out, timeout=120, extra=()):
    """Run an example or benchmark script (full path) with --quick --out OUT (and the extra arguments) in a child
    process."""
    env = dict(os.environ)
    # The child must find openmmflavors the way this process did.
    package_root = os.path.dirname(os.path.dirname(importlib.util.find_spec("openmmflavors").origin))
    env["PYTHONPATH"] = os.pathsep.join(p for p in [package_root, env.get("PYTHONPATH", "")] if p)
    # The scripts select Agg themselves; this also covers any pyplot import before that.
    env["MPLBACKEND"] = "Agg"
    return subprocess.run([sys.executable, script, "--quick", "--out", str(out), *extra], env=env,
                          capture_output=True, text=True, encoding="utf-8", timeout=timeout)


def assert_readme_table_reprinted(script, out, args, readme, observables, columns):
    """Run `script` with the table-printing `args` (and --quick --out OUT): it succeeds, and every row of the Markdown
    table it prints (a header, one row per observable, a count of runs; `columns` data columns) is in `readme`."""
    result = run_quick(script, out, extra=args)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(readme) as f:
        text = f.read()
    rows = [line for line in result.stdout.splitlines() if line.startswith("| ")]
    assert len(rows) == 1 + observables + 1, rows
    assert [row for row in rows if row not in text] == []
    assert rows[0].count(" | ") == columns


def pytest_configure(config):
    # A correct configuration gives no openmmflavors.FlavorsWarning; tests that expect one say so (pytest.warns).
    config.addinivalue_line("filterwarnings", "error::openmmflavors.FlavorsWarning")


def protein_recipe_flavor(seed=0):
    """The artificial FLAVOR of the protein and water recipes: ArtificialProjected, Middle placement, delta = 2 fs,
    tau = 0.5 fs, stiff group 1, 300 K at 1/ps."""
    integrator = FlavorIntegrator(2 * unit.femtoseconds, 0.5 * unit.femtoseconds, {STIFF_GROUP})
    integrator.setAveraging(FlavorIntegrator.ArtificialProjected)
    integrator.setThermostatPlacement(FlavorIntegrator.Middle)
    integrator.setTemperature(300 * unit.kelvin)
    integrator.setFriction(1 / unit.picosecond)
    integrator.setRandomNumberSeed(seed)
    return integrator


def assert_runs_complete(runs, observables):
    """Every run of a scene's JSON (label -> record) finished, stepped, and has each observable as a finite mean with
    an error that is non-negative (or NaN where a short run has one block)."""
    for label, run in runs.items():
        assert "failed" not in run, (label, run.get("failed"))
        assert run["ns_per_day"] > 0 and run["steps"] > 0
        for key in observables:
            value, error = run[key]
            assert math.isfinite(value) and (error >= 0 or math.isnan(error)), (label, key)

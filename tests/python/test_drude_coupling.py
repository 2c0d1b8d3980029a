"""examples/drude_water/drude_coupling.py: the shell's field, its Hessian and the curvature shares against independent
computations (OpenMM's forces, central differences, exact reductions)."""

import importlib.util
import math
import os

import numpy as np
import openmm
import openmm.unit as unit
import pytest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "drude_water", "drude_coupling.py")


@pytest.fixture(scope="module")
def module():
    spec = importlib.util.spec_from_file_location("drude_coupling", SCRIPT)
    loaded = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loaded)
    return loaded


def _lattice(module, molecules):
    system, _, positions, box = module.drude_water.build_water(molecules)
    x = np.array(positions.value_in_unit(unit.nanometer))
    analysis = module.drude_water.Analysis(system)
    # Drude particles 0.01 nm off their cores in random directions, so the Hessian is not a lattice's.
    rng = np.random.default_rng(5)
    x[analysis.drudes] += 0.01 * rng.standard_normal((len(analysis.drudes), 3))
    return system, x, box, analysis


def test_the_shell_field_of_a_cluster_is_openmms_coulomb_force(module):
    system, x, _, analysis = _lattice(module, 8)
    nonbonded = next(f for f in system.getForces() if isinstance(f, openmm.NonbondedForce))
    nonbonded.setNonbondedMethod(openmm.NonbondedForce.NoCutoff)
    context = openmm.Context(system, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(x)
    openmm_forces = context.getState(getForces=True, groups=1).getForces(asNumpy=True).value_in_unit(
        unit.kilojoule_per_mole / unit.nanometer)
    # With every molecule inside the shell and no periodic images, the shell's field on a Drude particle (no
    # Lennard-Jones there) is the whole Coulomb force.
    shell = module.Shells(analysis).pair_forces(x, 1000.0, 100.0)
    np.testing.assert_allclose(shell[0], openmm_forces[analysis.drudes], rtol=1e-6, atol=1e-6)
    # The central differences of OpenMM's soft forces give the analytic Hessian of that field.
    numeric = module.soft_drude_hessian(context, x, analysis.drudes, step=1e-5)
    analytic = module.Shells(analysis).drude_hessian(x, 1000.0, 100.0)
    assert np.abs(numeric - analytic).max() < 1e-5 * np.abs(analytic).max()


def test_the_shell_hessian_is_the_gradient_of_the_switched_shell_field(module):
    _, x, box, analysis = _lattice(module, 27)
    shells = module.Shells(analysis)
    analytic = shells.drude_hessian(x, box, 0.45)
    step = 1e-6
    numeric = np.zeros_like(analytic)
    for j, p in enumerate(analysis.drudes):
        for axis in range(3):
            plus, minus = x.copy(), x.copy()
            plus[p, axis] += step
            minus[p, axis] -= step
            numeric[:, 3 * j + axis] = -(shells.pair_forces(plus, box, 0.45)[0]
                                         - shells.pair_forces(minus, box, 0.45)[0]).ravel() / (2 * step)
    assert np.abs(numeric - analytic).max() < 1e-5 * np.abs(analytic).max()
    # Within the shell's smooth switch the weights lie in [0, 1] and vanish at the cutoff.
    assert module.switch(np.array([0.0, 0.35, 0.4, 0.45, 0.5]), 0.45).tolist() == pytest.approx([1, 1, 0.5, 0, 0])


def test_curvature_shares_are_exact_on_a_known_split(module):
    rng = np.random.default_rng(1)
    samples = 2 * int(round(max(module.CURVATURE_STEPS_FS) / module.SAMPLE_FS)) + 5
    shell = rng.standard_normal((samples, 4, 3))
    rows = module.curvature_shares(shell * 2, {0.45: shell, 0.6: shell * 2})
    for row in rows:
        assert row["beyond_share"]["0.45"] == pytest.approx(0.25)
        assert row["beyond_share"]["0.6"] == pytest.approx(0.0)


def test_a_plane_wave_on_a_full_lattice_has_all_its_weight_on_its_polarization(module):
    edge, side = 1.2, 3
    x = np.array([[i, j, k] for i in range(side) for j in range(side) for k in range(side)], float) * edge / side
    k = 2 * math.pi / edge * np.array([1.0, 0.0, 0.0])
    for direction, longitudinal in (([1.0, 0.0, 0.0], True), ([0.0, 1.0, 0.0], False)):
        wave = np.cos(x @ k)[:, None] * np.array(direction)
        wave = wave.ravel() / np.linalg.norm(wave)
        assert module.wave_weights(wave, x, edge, longitudinal=longitudinal, shells=1) == pytest.approx(1.0)
        assert module.wave_weights(wave, x, edge, longitudinal=not longitudinal, shells=1) == pytest.approx(0.0,
                                                                                                            abs=1e-12)


def test_the_script_writes_its_tables(tmp_path):
    import json
    import subprocess
    import sys
    result = subprocess.run([sys.executable, SCRIPT, "--frames", "1", "--samples", "20", "--molecules", "27",
                             "--out", str(tmp_path)], capture_output=True, text=True, encoding="utf-8", timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "drude_coupling.json") as f:
        report = json.load(f)
    frame = report["frames"][0]
    assert frame["full"][0] < 0 < frame["full"][1] and len(frame["stiffest"]) == 8
    assert [row["step_fs"] for row in report["curvature"]] == list(np.array([2.0, 2.5, 3.0, 3.5, 4.0]))
    for row in report["curvature"]:
        assert all(0 <= share for share in row["beyond_share"].values())
    bad = subprocess.run([sys.executable, SCRIPT, "--samples", "3"], capture_output=True, text=True, encoding="utf-8", timeout=600)
    assert bad.returncode != 0 and "--samples" in bad.stderr

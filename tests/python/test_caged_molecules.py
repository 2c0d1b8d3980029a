"""examples/drude_water/caged_molecules.py: each charge sits in the stated static field about its own cage, the
tethers pull where they should, and the quick run writes every peer."""
import importlib.util
import json
import math
import os
import sys

import conftest
import numpy as np
import openmm
import openmm.unit as unit
import pytest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "drude_water", "caged_molecules.py")
CAGE_GROUP = 7


def _module():
    sys.path.insert(0, os.path.dirname(SCRIPT))
    spec = importlib.util.spec_from_file_location("caged_molecules", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _field(e0, g, r):
    """-grad of phi(r) = -E0 (0.6, 0, 0.8) . r - g/2 (x^2 + y^2 - 2 z^2 + x y), written out by hand."""
    x, y, z = r
    return np.array([0.6 * e0 + g * (x + y / 2), g * (y + x / 2), 0.8 * e0 - 2 * g * z])


def _cage_forces(system, positions):
    cage = next(f for f in system.getForces() if isinstance(f, openmm.CustomExternalForce))
    cage.setForceGroup(CAGE_GROUP)
    context = openmm.Context(system, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions * unit.nanometer)
    forces = context.getState(getForces=True, groups={CAGE_GROUP}).getForces(asNumpy=True)
    return cage, forces.value_in_unit(unit.kilojoule_per_mole / unit.nanometer)


def test_each_charge_feels_the_stated_field_about_its_oxygen_and_the_tethers_pull_back():
    module = _module()
    e0, g, trap_o, trap_h = 1200.0, 2.5e4, 9e4, 1.5e4
    system, start, analysis = module.build_caged(3, e0, g, trap_o, trap_h)
    moved = start + np.random.default_rng(3).normal(scale=0.01, size=start.shape)
    cage, forces = _cage_forces(system, moved)
    # A Drude particle carries no virtual site's share of force and no tether: its force is its charge's q E alone.
    for drude, core in zip(analysis.drudes, analysis.cores):
        q = cage.getParticleParameters(int(drude))[1][0]
        expected = q * _field(e0, g, moved[drude] - start[core])
        assert forces[drude] == pytest.approx(expected, rel=1e-9)
        assert module.cage_field(e0, g, moved[drude] - start[core]) == pytest.approx(_field(e0, g, moved[drude] -
                                                                                            start[core]))
    # The cage's forces on the massive particles (a virtual site's handed on to its parents; OpenMM also reports it on
    # the site itself) add up to q E over every charge plus the tethers.
    total = np.zeros(3)
    for block in analysis.blocks:
        centre = start[block[0]]
        for i in block:
            q = cage.getParticleParameters(int(i))[1][0]
            total += q * _field(e0, g, moved[i] - centre)
            if i in set(analysis.cores):
                total -= trap_o * (moved[i] - start[i])
            elif i in set(analysis.hydrogens):
                total -= trap_h * (moved[i] - start[i])
    massive = [i for i in range(system.getNumParticles()) if not system.isVirtualSite(i)]
    assert forces[massive].sum(axis=0) == pytest.approx(total, rel=1e-9, abs=1e-6)
    assert analysis.com_dof == 3 * (len(analysis.cores) + len(analysis.hydrogens)) - system.getNumConstraints()
    assert not any(isinstance(f, openmm.NonbondedForce) for f in system.getForces())


def test_free_pairs_are_swm4_ndp_drude_pairs_with_only_the_core_tethered():
    module = _module()
    e0, g, trap_o = 1500.0, 3e4, 1e5
    system, start, analysis = module.build_free_pairs(2, e0, g, trap_o)
    assert system.getNumConstraints() == 0 and system.getNumParticles() == 4
    assert analysis.masses[analysis.cores] + analysis.masses[analysis.drudes] == pytest.approx([16.0, 16.0], abs=1e-3)
    moved = start + np.random.default_rng(4).normal(scale=0.01, size=start.shape)
    cage, forces = _cage_forces(system, moved)
    for core, drude in zip(analysis.cores, analysis.drudes):
        q = cage.getParticleParameters(int(drude))[1][0]
        assert q == pytest.approx(-cage.getParticleParameters(int(core))[1][0])
        centre = start[core]
        assert forces[drude] == pytest.approx(q * _field(e0, g, moved[drude] - centre), rel=1e-9)
        assert forces[core] == pytest.approx(-q * _field(e0, g, moved[core] - centre)
                                             - trap_o * (moved[core] - start[core]), rel=1e-9)


def test_peers_are_parsed_and_bad_ones_named():
    module = _module()
    assert module.parse_peer("WarpedMiddleScaled:2.5") == ("WarpedMiddleScaled:2.5", "WarpedMiddleScaled", 2.5, None)
    assert module.parse_peer("Twin:0.5:2.5:2.05") == ("Twin:0.5:2.5:2.05", "DrudeLangevin", 0.5, (2.5, 2.05))
    for bad in ("WarpedMiddle", "WarpedMiddle:-1", "Twin:0.5:2.5", "Twin:0.5:2.5:4"):
        with pytest.raises(ValueError, match="peer"):
            module.parse_peer(bad)


@pytest.mark.parametrize("extra", [(), ("--free-pairs",)])
def test_caged_molecules_quick_writes_every_peer(tmp_path, extra):
    result = conftest.run_quick(SCRIPT, tmp_path, timeout=300,
                                extra=("--peers", "DrudeLangevin:0.5", "WarpedMiddleScaled:2.5", "Twin:0.5:2.5:2.05",
                                       *extra))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "caged_molecules.json") as f:
        report = json.load(f)
    assert report["free_pairs"] == bool(extra)
    assert list(report["peers"]) == ["DrudeLangevin:0.5", "WarpedMiddleScaled:2.5", "Twin:0.5:2.5:2.05"]
    for peer in report["peers"].values():
        for name in ("t_com", "t_drude", "cage_energy"):
            assert math.isfinite(peer[name][0]) and peer[name][1] >= 0
        # A 1-K Drude bath holds the Drudes cold; the field polarizes them by about its q E / k.
        assert peer["t_drude"][0] < 20 and 0.003 < peer["drude_displacement_nm"] < 0.03


def test_the_molecules_bath_temperature_and_the_seed_reach_the_run(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path, timeout=300,
                                extra=("--peers", "DrudeLangevin:0.5", "--temperature", "250", "--seed", "3"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "caged_molecules.json") as f:
        report = json.load(f)
    assert report["temperature"] == 250 and report["seed"] == 3
    # 32 molecules, 0.2 ps: a standard error near 7 K; 1 ps of burn-in at 5/ps brings them from the 300-K start.
    t_com, error = report["peers"]["DrudeLangevin:0.5"]["t_com"]
    assert abs(t_com - 250) < 25 and error < 12


def test_the_seed_table_pools_replicas_and_names_other_baths(tmp_path):
    module = _module()
    files = []
    for n, (bath, t_ref, t_sim) in enumerate([(300.0, 299.0, 298.0), (300.0, 299.4, 298.6), (297.0, 296.0, None)]):
        peers = {"DrudeLangevin:0.25": {"t_com": [t_ref, 0.3], "t_drude": [1.5, 0.001], "cage_energy": [-208.6, 0.01]}}
        if t_sim is not None:
            peers["WarpedMiddle:1"] = {"t_com": [t_sim, 0.4], "t_drude": [1.4, 0.001], "cage_energy": [-208.7, 0.01]}
        files.append(str(tmp_path / f"r{n}.json"))
        with open(files[-1], "w") as f:
            json.dump({"temperature": bath, "peers": peers}, f)
    lines = module.seed_table(files, "DrudeLangevin:0.25").splitlines()
    assert lines[0] == "| observable | DrudeLangevin:0.25 | WarpedMiddle:1 | DrudeLangevin:0.25 @ 297 K |"
    reference_se, sim_se = math.hypot(0.3, 0.3) / 2, math.hypot(0.4, 0.4) / 2
    assert lines[2].startswith("| T molecules (K) | 299.20 ± %.2f | 298.30 ± %.2f (%+.1f) | 296.00 ± 0.30 (" % (
        reference_se, sim_se, -0.9 / math.hypot(reference_se, sim_se)))
    assert lines[-1] == "| runs | 2 | 2 | 1 |"
    with pytest.raises(ValueError, match="Twin:0.5:2.5:2.05"):
        module.seed_table(files, "Twin:0.5:2.5:2.05")


def test_nve_reports_each_peers_energy_drift_and_verlet_keeps_the_energy(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path, timeout=300,
                                extra=("--nve", "--peers", "Verlet:0.25", "WarpedMiddle:2.5"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "caged_molecules.json") as f:
        report = json.load(f)
    assert report["nve"] is True
    verlet, sim = report["peers"]["Verlet:0.25"], report["peers"]["WarpedMiddle:2.5"]
    # Velocity Verlet with rigid water at 0.25 fs keeps the energy (measured 1e-6 kJ/mol/ps per molecule).
    assert abs(verlet["drift_per_molecule"]) < 1e-3
    assert math.isfinite(sim["drift_per_molecule"]) and all(t > 0 for t in sim["t_com_first_last"])
    refused = conftest.run_quick(SCRIPT, tmp_path, timeout=300, extra=("--nve", "--peers", "DrudeLangevin:0.5"))
    assert refused.returncode != 0 and "Verlet:H" in refused.stderr


def test_the_readme_replica_table_is_the_stored_replicas():
    module = _module()
    results = os.path.join(REPO_ROOT, "examples", "drude_water", "results", "caged")
    files = [os.path.join(results, "field", "caged_molecules.json")]
    replicas = os.path.join(results, "replicas")
    files += [os.path.join(replicas, name, "caged_molecules.json") for name in sorted(os.listdir(replicas))]
    table = module.seed_table(files, "DrudeLangevin:0.25").splitlines()
    header = [cell.strip() for cell in table[0].split("|")[1:-1]]
    temperatures = dict(zip(header, (cell.strip() for cell in table[2].split("|")[1:-1])))
    with open(os.path.join(REPO_ROOT, "examples", "drude_water", "README.md"), encoding="utf-8") as f:
        readme = f.read()
    for peer in ("DrudeLangevin:0.25", "DrudeLangevin:0.125", "DrudeLangevin:0.5", "WarpedMiddle:0.5",
                 "WarpedMiddle:1", "WarpedMiddleScaled:2.5", "DrudeLangevin:0.25 @ 297 K", "Twin:0.25:2.5:2.05"):
        cell = temperatures[peer].split(" (")[0]
        assert cell in readme, (peer, cell)

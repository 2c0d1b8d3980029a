"""Smoke test of examples/drude_protein: the --quick run of alanine dipeptide in Drude-2019 (anisotropic and
Thole-screened Drude particles, lone pairs, X-H constraints on cores that carry Drude particles) in SWM4-NDP water
writes its JSON with every observable, and the SIM with the hard wall keeps the induced dipoles self-consistent and the
Drudes cold."""
import json
import math
import os
import sys

import conftest
import pytest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "drude_protein", "drude_protein.py")
OBSERVABLES = ["t_peptide", "t_water", "t_drude", "induced_ratio_peptide", "induced_ratio_water", "rmsd_nm",
               "bond_width_nm", "angle_width_deg", "phi_deg", "extended", "pe_per_pair"]


@pytest.mark.long
def test_drude_protein_quick(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "drude_protein.json") as f:
        data = json.load(f)
    runs = {(run["integrator"], run["step_fs"], run["wall_nm"]): run for run in data["runs"]}
    assert set(runs) == {("DrudeLangevin", 0.5, 0.0), ("DrudeLangevin", 1.0, 0.02), ("WarpedMiddle", 2.0, 0.02)}
    conftest.assert_runs_complete(runs, OBSERVABLES)
    for label, run in runs.items():
        # Loose sanity bounds on the short run (not the example's claims).
        assert abs(run["induced_ratio_peptide"][0] - 1) < 0.1, label
        assert abs(run["induced_ratio_water"][0] - 1) < 0.05, label
        assert run["t_drude"][0] < 20, label
        assert run["rmsd_nm"][0] < 0.1, label


@pytest.mark.long
def test_step_limit_probe_quick(tmp_path):
    """The --quick probe runs the SIM on the peptide as it is and with the Thole screening off, one record per run."""
    script = os.path.join(REPO_ROOT, "examples", "drude_protein", "step_limit_probe.py")
    for extra in ((), ("--thole-off",), ("--max-warped-phase", "1.77", "--steps", "2.5")):
        result = conftest.run_quick(script, tmp_path, extra=extra)
        assert result.returncode == 0, result.stderr[-3000:]
        with open(tmp_path / "step_limit_probe.json") as f:
            data = json.load(f)
        assert data["args"]["thole_off"] == ("--thole-off" in extra)
        assert data["args"]["max_warped_phase"] == (1.77 if "--max-warped-phase" in extra else 0.0)
        assert len(data["runs"]) == 1
        run = data["runs"][0]
        assert run["failed"] is None and run["ps"] > 0 and math.isfinite(run["hottest_drude_K"]), run


def stored_runs(folder, seeds=range(1, 6)):
    return [os.path.join(REPO_ROOT, "examples", "drude_protein", "results", *folder, f"seed{s}", "drude_protein.json")
            for s in seeds]


TEN_SEEDS_2FS = stored_runs(("density",)) + stored_runs(("density", "more_seeds_2fs"), range(6, 11))


@pytest.mark.parametrize("sim_files, reference_files, reference_step, columns", [
    (stored_runs(("friction_scaling",)), stored_runs(()), 0.5, 4),   # the reference's five runs, SIM 2, 2.5, 3 fs
    (stored_runs(("density",)), stored_runs(("density",)), 0.5, 3),  # the reference, DL 1 fs + wall, SIM 2 fs
    (stored_runs(("density_phase_limit_scaled",)), stored_runs(("density",)), 0.5, 3),   # the reference, SIM 2.5, 3 fs
    (stored_runs(("density",)), stored_runs(("density_dl025",)), 0.25, 4),   # DL 0.25, 0.5, 1 fs + wall, SIM 2 fs
    (stored_runs(("density_phase_limit_scaled",)), stored_runs(("density_dl025",)), 0.25, 3),   # DL 0.25, SIM 2.5, 3
    (TEN_SEEDS_2FS, stored_runs(("density_dl025",)), 0.25, 4),   # DL 0.25, 0.5, 1 fs + wall, SIM 2 fs over ten seeds
])
def test_seed_table_reprints_the_readme_table_from_the_stored_runs(tmp_path, sim_files, reference_files,
                                                                  reference_step, columns):
    conftest.assert_readme_table_reprinted(
        SCRIPT, tmp_path, ("--seed-table", *sim_files, "--reference-files", *reference_files,
                           "--reference-step", str(reference_step)),
        os.path.join(REPO_ROOT, "examples", "drude_protein", "README.md"), 11, columns)


def test_anisotropic_flow_quick_takes_the_fixed_axes_terms_into_the_flow_or_leaves_them_soft(tmp_path):
    """Flow holds three relative modes per pair at sqrt(k_a / mu) (k_a = k + k1, k + k2, k along the axes), Soft one
    (the isotropic spring's); every peer writes every observable.  Plain Warped at 3 fs (phase 2.26) is stable under a
    soft stiffness r k along a mode only while (1 + r) sin^2(phase / 2) < 1, r < 0.22: with k1 = +0.255 k soft it
    blows up, in the flow it runs."""
    script = os.path.join(REPO_ROOT, "examples", "drude_protein", "anisotropic_flow.py")
    peers = ["DrudeLangevin:0.5", "Soft:2", "Flow:2", "Soft:3:1.77", "Flow:3:1.77", "Soft:3", "Flow:3"]
    result = conftest.run_quick(script, tmp_path, extra=("--peers", *peers))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "anisotropic_flow.json") as f:
        data = json.load(f)
    assert list(data["peers"]) == peers
    assert "a Drude particle" in data["peers"].pop("Soft:3")["failed"]
    k = data["k"]
    mu = 15.5994 * 0.4 / (15.5994 + 0.4)
    expected = sorted(round(math.sqrt(k * (1 + r) / mu), 1) for r in (data["k1_over_k"], data["k2_over_k"], 0.0))
    for label, run in data["peers"].items():
        for name in ("induced_u1", "induced_u2", "induced_u3", "t_drude", "t_drude_config", "t_cores"):
            assert math.isfinite(run[name][0]) and run[name][1] >= 0, (label, name)
        # Loose sanity bounds on the short run (not the example's claims).
        assert abs(run["induced_u1"][0] - 1) < 0.05 and run["t_drude"][0] < 20, label
        if label.startswith("Flow"):
            assert run["stiff_mode_frequencies_per_ps"] == pytest.approx(expected, abs=0.11), label
        elif label.startswith("Soft"):
            assert run["stiff_mode_frequencies_per_ps"] == pytest.approx([expected[1]], abs=0.11), label


def test_anisotropic_flow_rejects_a_peer_it_cannot_run(tmp_path):
    script = os.path.join(REPO_ROOT, "examples", "drude_protein", "anisotropic_flow.py")
    conftest.assert_cli_rejects(script, tmp_path, ("--peers", "DrudeLangevin:0.5:1.77"),
                                "expected DrudeLangevin:H, Soft:H[:PHASE] or Flow:H[:PHASE]")


@pytest.mark.parametrize("folder, replicas", [("carbonyl", 2), ("villin_extremes", 1)])
def test_anisotropic_flow_seed_table_reprints_the_readme_table_from_the_stored_runs(tmp_path, folder, replicas):
    script = os.path.join(REPO_ROOT, "examples", "drude_protein", "anisotropic_flow.py")
    stored = [os.path.join(REPO_ROOT, "examples", "drude_protein", "results", "anisotropic_flow", folder, f"seed{s}",
                           "anisotropic_flow.json") for s in range(1, replicas + 1)]
    # A row per peer (14) beside the header: the helper counts them as a header, 13 rows and a last one.
    conftest.assert_readme_table_reprinted(script, tmp_path, ("--seed-table", *stored),
                                           os.path.join(REPO_ROOT, "examples", "drude_protein", "README.md"), 13, 7)


def warped_phase(omega, h):
    """Plain Warped's phase per step for a mode of omega (1/ps) at h (ps), without friction (heat_model's warped
    frequency: xi~ tan(xi~ / 2) = (omega h)^2 / 2)."""
    sys.path.insert(0, os.path.join(REPO_ROOT, "examples", "drude_water"))
    import heat_model
    return heat_model.warped_frequency(omega, 0.0, h) * h


def test_drude_coupling_quick_puts_the_dipeptides_step_limit_between_2_and_2_25_fs(tmp_path):
    """The soft stiffness along the peptide's Drude modes, measured from OpenMM's forces, against the step limit that
    step_limit_probe.py found by running (plain Warped holds at 2 fs and fails at 2.25 fs): Warped is stable while
    (1 + r) sin^2(phase / 2) < 1, so the largest r must lie between the thresholds of the two steps' phases."""
    script = os.path.join(REPO_ROOT, "examples", "drude_protein", "drude_coupling.py")
    result = conftest.run_quick(script, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "drude_coupling.json") as f:
        data = json.load(f)
    assert data["drude_pairs"] == 10
    omega = math.sqrt(418400 / (0.4 * 11.611 / 12.011))  # the C-alpha pair's spring and reduced mass, 1/ps
    threshold = {h: 1 / math.sin(warped_phase(omega, h * 1e-3) / 2)**2 - 1 for h in (2.0, 2.25)}
    assert threshold[2.25] < data["r_max"] < threshold[2.0], (data["r_max"], threshold)
    assert data["max_stable_phase"] == pytest.approx(2 * math.asin(1 / math.sqrt(1 + data["r_max"])))

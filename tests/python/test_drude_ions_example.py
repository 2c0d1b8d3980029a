"""Smoke test of examples/drude_ions: the --quick run of NaCl in SWM4-NDP water (Drude-2019 ions) writes its JSON,
and the SIM on the System split by separateDrudeSprings keeps the induced dipoles self-consistent and the Drudes
cold."""
import json
import math
import os

import conftest
import pytest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "drude_ions", "drude_ions.py")
OBSERVABLES = ["induced_ratio", "induced_ratio_ions", "t_drude", "t_com", "pe_per_pair"]


def test_drude_ions_quick(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "drude_ions.json") as f:
        data = json.load(f)
    assert data["ions"] == {"NA": 2, "CL": 2}
    runs = {(run["integrator"], run["step_fs"]): run for run in data["runs"]}
    assert set(runs) == {("DrudeLangevin", 0.5), ("WarpedMiddle", 1.5), ("WarpedMiddle", 2.0)}
    conftest.assert_runs_complete(runs, OBSERVABLES)
    for label, run in runs.items():
        # Loose sanity bounds on the short run (not the example's claims).
        assert abs(run["induced_ratio"][0] - 1) < 0.05, label
        assert abs(run["induced_ratio_ions"][0] - 1) < 0.1, label
        assert run["t_drude"][0] < 20, label


def test_stability_probe_quick(tmp_path):
    """The --quick probe runs the SIM with and without the hard wall and writes one record per run."""
    script = os.path.join(REPO_ROOT, "examples", "drude_ions", "stability_probe.py")
    result = conftest.run_quick(script, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "stability_probe.json") as f:
        runs = json.load(f)["runs"]
    assert sorted(run["wall_nm"] for run in runs) == [0.0, 0.02]
    for run in runs:
        assert run["failed"] is None and run["ps"] > 0 and math.isfinite(run["hottest_drude_K"]), run


@pytest.mark.parametrize("folder, columns", [("density_wall", 4), ("density", 3)])
def test_seed_table_reprints_the_readme_tables_from_the_stored_runs(tmp_path, folder, columns):
    stored = [os.path.join(REPO_ROOT, "examples", "drude_ions", "results", folder, f"seed{s}", "drude_ions.json")
              for s in range(1, 6)]
    conftest.assert_readme_table_reprinted(SCRIPT, tmp_path, ("--seed-table", *stored),
                                           os.path.join(REPO_ROOT, "examples", "drude_ions", "README.md"), 5, columns)

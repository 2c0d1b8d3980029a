"""Smoke tests of the StochasticImpulseIntegrator example scenes (examples/sim_two_springs, examples/sim_fpu): each
runs with --quick in a child process and writes its JSON and PNG."""
import json
import math
import os

import pytest

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = os.path.join(REPO_ROOT, "examples")


def run_quick(script, out):
    return conftest.run_quick(os.path.join(EXAMPLES, script), out)


def load(path):
    with open(path) as f:
        return json.load(f)


def test_two_springs_quick(tmp_path):
    result = run_quick(os.path.join("sim_two_springs", "sim_two_springs.py"), tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    data = load(tmp_path / "sim_two_springs.json")
    assert {"scene", "model", "platform", "parameters", "runs", "comparison", "series"} <= set(data)
    p = data["parameters"]
    assert p["omega"] == 100.0 and p["c"] == 0.1 and p["beta"] == 10.0
    assert p["kT_kJ_per_mol"] == pytest.approx(0.1)
    assert p["temperature_K"] == pytest.approx(0.1 / 0.0083144626, rel=1e-8)
    assert p["omega_H_over_pi"] == pytest.approx(10.0)
    assert p["gla_h"] <= 0.1 / p["omega"] * (1 + 1e-12)
    sims = {"sim_lietrotter", "sim_strang", "sim_lietrotter_nonresonant", "sim_strang_nonresonant"}
    assert set(data["runs"]) == sims | {"gla", "gla_fine"}
    for key, run in data["runs"].items():
        assert run["wall_s"] > 0 and run["steps"] >= 1
        for value, error in run["moments_at_T"].values():
            assert math.isfinite(value) and error >= 0
    for key in sims:
        assert data["runs"][key]["speedup_vs_gla"] > 1
        for reference in ("gla", "gla_fine"):
            comparison = data["comparison"][f"{key} vs {reference}"]
            assert set(comparison["moments"]) == {"E[x]", "E[y]", "E[x^2]", "E[y^2]", "E[px^2]", "E[py^2]"}
            assert comparison["positions"]["comparisons"] > 0
    # Every realization starts at the paper's x(0) = 0.8/omega, y(0) = 1.1 + x(0).
    first = data["series"]["gla"]["mean"][0]
    assert first[0] == pytest.approx(0.008) and first[1] == pytest.approx(1.108)
    assert (tmp_path / "sim_two_springs.png").stat().st_size > 0


def test_fpu_quick(tmp_path):
    result = run_quick(os.path.join("sim_fpu", "sim_fpu.py"), tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    data = load(tmp_path / "sim_fpu.json")
    assert {"scene", "platform", "parameters", "summary", "series"} <= set(data)
    summary = data["summary"]
    assert {"reference", "reference_check", "verlet", "sim_lietrotter_H0.01", "sim_strang_H0.01",
            "sim_lietrotter_H0.002", "sim_strang_H0.002"} <= set(summary)
    # The reference's own error estimate must be far below the differences it is used to measure.
    assert summary["reference"]["x0_1_error_max"] < 1e-6
    # Strang at H = 0.002 (omega H = 0.4) follows the slow variable closely over the short quick run.
    assert summary["sim_strang_H0.002"]["x0_1_error_max"] < 1e-3
    for s in summary.values():
        assert s["wall_s"] > 0 and len(s["I_T"]) == 3
        assert all(math.isfinite(v) for v in s["I_T"])
    assert (tmp_path / "sim_fpu.png").stat().st_size > 0

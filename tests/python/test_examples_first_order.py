"""The first-order scenes (examples/van_der_pol, examples/hidden_sde): each runs with --quick, exits 0, writes its JSON
and PNG, and its numbers are what the scene claims to measure."""
import json
import os

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = os.path.join(REPO_ROOT, "examples")


def run_scene(name, out):
    result = conftest.run_quick(os.path.join(EXAMPLES, name, name + ".py"), out)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (out / f"{name}.png").stat().st_size > 0
    with open(out / f"{name}.json") as f:
        return json.load(f)


def test_van_der_pol_quick(tmp_path):
    data = run_scene("van_der_pol", tmp_path)
    assert set(data["runs"]) == {"euler_cartesian", "flavor_cartesian", "euler_polar", "flavor_polar"}
    errors = data["errors"]
    # Forward Euler at h = 0.05 eps is close to the Radau reference on (6.2); the FLAVOR follows it closely over
    # the quick run's half period (no jump yet), with 200 times fewer mesosteps than forward Euler's steps.
    assert errors["euler_cartesian"]["max_abs_x"] < 1e-6
    assert errors["flavor_cartesian"]["max_abs_x"] < 1e-3
    assert errors["flavor_polar"]["max_abs_x"] < 0.05
    for system in ("cartesian", "polar"):
        assert errors[f"flavor_{system}"]["step_ratio"] == 200
        assert errors[f"flavor_{system}"]["speedup_cpu"] > 10


def test_hidden_sde_quick(tmp_path):
    data = run_scene("hidden_sde", tmp_path)
    cmp = data["comparisons"]
    # (6.16) and its form in (x, y) are the same SDE on the same Brownian paths: the same E x up to the rounding of
    # the change of variables.
    assert cmp["euler_slowfast_vs_euler"]["max_abs"] < 1e-3
    # Euler-Maruyama at h = eps samples y with variance 2 and follows the averaged equation with that variance.
    assert abs(cmp["euler_vs_its_averaged_limit"]["at_T_in_se"]) < 4
    assert abs(cmp["flavor_vs_euler"]["at_T_in_se"]) < 5
    assert data["speedups"]["paper"]["steps"] == 100 and data["speedups"]["resolved"]["steps"] == 1000
    assert data["speedups"]["paper"]["cpu"] > 10
    for run in data["runs"].values():
        assert run["cpu_s"] > 0 and len(run["t"]) == len(run["mean_x"])

"""Smoke test of examples/stability_5_1: --quick finds the stability domains of Fig. 5.1 by running, every verdict
agrees with the one-step matrix, and the artificial FLAVOR's domain is the larger one."""
import json
import os

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "stability_5_1", "stability_5_1.py")


def test_quick_run_finds_both_domains(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "stability_5_1.png").stat().st_size > 0
    with open(tmp_path / "stability_5_1.json") as f:
        data = json.load(f)
    domains = data["domains"]
    for name in ("Nonintrusive", "Artificial"):
        assert domains[name]["runs_agreeing_with_matrix"] == domains[name]["runs"] > 0
    stable = {name: sum(s == 1 for row in domains[name]["stable"] for s in row) for name in domains}
    assert stable["Artificial"] > stable["Nonintrusive"] > 0
    # Theorem 5.1 at small tau: the boundaries 2 and 2 sqrt(2), resolved by the coarse grid (step 0.49).
    assert 1.5 < domains["Nonintrusive"]["largest_stable_delta_at_smallest_tau"] <= 2.0
    assert 2.0 < domains["Artificial"]["largest_stable_delta_at_smallest_tau"] <= 2 * 2 ** 0.5


def test_quick_error_run_converges_with_the_mesostep(tmp_path):
    """--errors (Fig. 5.2): the error at the optimal microstep shrinks as the mesostep does, for both averagings, and
    the artificial FLAVOR's error at a fixed mesostep hardly depends on the microstep."""
    result = conftest.run_quick(SCRIPT, tmp_path, extra=["--errors"])
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "errors_5_2.png").stat().st_size > 0
    with open(tmp_path / "errors_5_2.json") as f:
        data = json.load(f)
    for name in ("Nonintrusive", "Artificial"):
        best = data["averagings"][name]["optimal_error"]
        assert best[0] < best[-1] / 10, (name, best)
    # At the largest mesostep every microstep gives the artificial FLAVOR the same error to 10 %.
    column = [row[-1] for row in data["averagings"]["Artificial"]["error"] if row[-1] is not None]
    assert len(column) >= 3 and max(column) < 1.1 * min(column), column

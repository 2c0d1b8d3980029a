"""Smoke test of examples/fpu_artificial: --quick (T = 5) runs the reference and every FLAVOR averaging on the FPU
chain and writes its JSON and PNG; the artificial FLAVOR tracks the reference's stiff energies."""
import json
import os

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "fpu_artificial", "fpu_artificial.py")


def test_quick_run_writes_json_and_png(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "fpu_artificial.png").stat().st_size > 0
    with open(tmp_path / "fpu_artificial.json") as f:
        data = json.load(f)
    runs = data["runs"]
    assert len(runs) == 5 and all(run["stable"] for run in runs.values())
    artificial = runs["FLAVOR Artificial δ=0.002 τ=0.0005"]
    nonintrusive = runs["FLAVOR Nonintrusive δ=0.002 τ=0.0005"]
    # Over t <= 5 the first spring keeps its energy 1/2 in the reference; the artificial FLAVOR follows it to 0.05
    # (measured 0.028), the nonintrusive one loses most of it (measured 0.37: its springs are weakened to tau/delta).
    assert artificial["max_error_I"][0] < 0.05
    assert nonintrusive["max_error_I"][0] > 0.2


def test_quick_long_run_writes_json_and_png(tmp_path):
    """--long (Fig. 6.8) with --quick (T = 20): every run stays finite; velocity Verlet at h = 1e-4 and the impulse
    method (exact stiff flow) keep H to 1e-3 (measured 4e-5 and 6e-5), while the artificial FLAVOR, which does not
    integrate H itself, keeps the total stiff energy within 10 % of its start (measured 5 %)."""
    result = conftest.run_quick(SCRIPT, tmp_path, extra=["--long"])
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "fpu_long.png").stat().st_size > 0
    with open(tmp_path / "fpu_long.json") as f:
        runs = json.load(f)["runs"]
    assert len(runs) == 3 and all(run["stable"] for run in runs.values())
    for name in ("Verlet h=1e-4", "SIM Strang H=0.002 (impulse method, exact stiff flow)"):
        low, high = runs[name]["H_range"]
        assert high - low < 1e-3, (name, low, high)
    low, high = runs["FLAVOR Artificial δ=0.002 τ=0.0005"]["I_total_range"]
    assert 0.45 < low and high < 0.55, (low, high)

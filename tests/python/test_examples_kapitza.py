"""examples/kapitza: with --quick it exits 0, writes its JSON and PNG, and the FLAVOR on the stiff clock keeps the
pendulum inverted with the reference's slow period, while the FLAVOR on physical time lets it fall."""
import json
import os

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "kapitza", "kapitza.py")

# The slow period of the FLAVOR on the stiff clock against the reference's over the quick run's two periods.
PERIOD_TOLERANCE = 0.03


def test_kapitza_quick(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "kapitza.png").stat().st_size > 0
    with open(tmp_path / "kapitza.json") as f:
        data = json.load(f)
    s = data["summary"]
    # The reference oscillates about the top with Kapitza's effective-potential period (to a few per cent: the
    # averaging is first order in 1/omega).
    assert s["reference"]["stays_inverted"]
    assert abs(s["reference"]["period_vs_kapitza"]) < 0.05
    # tau = delta is velocity Verlet on physical time: the reference's trajectory to rounding.
    assert s["verlet"]["max_abs_diff_from_reference"] < 1e-9
    # On the stiff clock the inverted position stays stable, with the reference's slow period.
    assert s["flavor_clock"]["stays_inverted"]
    assert s["flavor_clock"]["max_abs_theta"] < 0.5
    assert abs(s["flavor_clock"]["period_vs_reference"]) < PERIOD_TOLERANCE
    assert s["flavor_clock"]["step_ratio"] == 30
    # On physical time the forcing aliases (2 pi omega delta = 4 pi) and the pendulum falls.
    assert not s["flavor_physical"]["stays_inverted"]

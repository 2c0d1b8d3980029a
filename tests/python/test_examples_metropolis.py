"""examples/metropolis: with --quick it exits 0, writes its JSON and PNG, the acceptance falls with system size,
every effective-sample-size entry (spring pairs, dipeptide, FPU chains) is a finite positive number, and the FPU
chains' exact averages are the quadrature's."""
import json
import math
import os

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "metropolis", "metropolis.py")


def test_metropolis_quick(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "metropolis.png").stat().st_size > 0
    with open(tmp_path / "metropolis.json") as f:
        data = json.load(f)
    adjusted = {(r["scheme"], r["N"], r["x"]): r for r in data["part1"] if r["adjusted"]}
    for r in adjusted.values():
        assert 0.0 <= r["acceptance"] <= 1.0
        assert r["acceptance"] == r["acceptance"]
    # Strang SIM at omega_soft H = 1: about 0.83 accepted for one pair, 0.5 for ten (500 proposals each).
    assert adjusted[("sim_strang", 1, 1.0)]["acceptance"] > adjusted[("sim_strang", 10, 1.0)]["acceptance"] + 0.1
    # The nonintrusive FLAVOR at omega delta = 14 accepts (almost) nothing; the artificial one a useful fraction.
    assert adjusted[("flavor_nonintrusive", 10, 1.0)]["acceptance"] < 0.05
    assert adjusted[("flavor_artificial", 10, 1.0)]["acceptance"] > 0.2
    for scene in ("pairs", "dipeptide", "fpu"):
        part = data["part2"][scene]
        for peer in part["peers"].values():
            assert peer["finite"]
            for name, value in peer.items():
                if isinstance(value, dict):
                    assert value["ess_per_s"] > 0 and math.isfinite(value["ess_per_s"]), (scene, name)
        if scene == "fpu":
            # Exact averages of 10 chains x 3 coordinates (transfer-matrix quadrature).
            assert abs(part["U_exact"] - 168.3649) < 1e-3 and abs(part["X0sq_exact"] - 1.002490) < 1e-5
            continue
        cost = data["part2"]["step_cost"][scene]
        assert cost["adjusted_over_unadjusted"]["median"] > 0
        assert cost["adjusted_over_langevin"]["median"] > 0
    for point in data["part2"]["dipeptide"]["acceptance_grid"]:
        assert 0.0 <= point["acceptance"] <= 1.0

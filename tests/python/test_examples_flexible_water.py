"""Smoke test of examples/flexible_water: --quick runs every kind of peer on the 1,503-atom flexible TIP3P box, exits
0 and writes its JSON and PNG; every peer stays finite and the artificial FLAVOR keeps the O-H bonds at the
reference's length."""
import json
import math
import os

import pytest

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "flexible_water", "flexible_water.py")


@pytest.mark.long
def test_quick_run_writes_json_and_png(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "flexible_water.png").stat().st_size > 0
    with open(tmp_path / "flexible_water.json") as f:
        data = json.load(f)
    assert data["atoms"] == 1503 and data["quick"]
    names = [peer["name"] for peer in data["peers"]]
    assert names[0] == "LangevinMiddle flexible 0.25 fs"
    assert any(name.startswith("FLAVOR Nonintrusive") for name in names)
    assert any(name.startswith("FLAVOR ArtificialProjected") for name in names)
    for peer in data["peers"]:
        assert peer["stable"], peer
        for key in ("oh_mean", "angle_mean", "pe_per_molecule", "T_O", "T_H", "ns_per_day", "g_OO_peak"):
            assert math.isfinite(peer[key]), (peer["name"], key)
    reference = data["peers"][0]
    artificial = next(p for p in data["peers"] if p["name"].startswith("FLAVOR ArtificialProjected"))
    # Frozen bonds at full strength: the mean O-H length stays the reference's (0.097 nm) to 1e-3 nm; the
    # nonintrusive FLAVOR's weakened bonds stretch by several times that.
    assert abs(artificial["oh_mean"] - reference["oh_mean"]) < 1e-3
    assert 0.095 < reference["oh_mean"] < 0.099


@pytest.mark.long
def test_peers_option_runs_only_the_named_peers(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--peers", "0.25 fs", "+angles"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "flexible_water.json") as f:
        names = [peer["name"] for peer in json.load(f)["peers"]]
    assert names == ["LangevinMiddle flexible 0.25 fs", "FLAVOR ArtificialProjected +angles δ=2 fs τ=0.5 fs",
                     "FLAVOR ArtificialProjected +angles Middle δ=2 fs τ=0.5 fs"]


def test_peers_option_that_matches_nothing_is_an_error(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--peers", "no such peer"))
    assert result.returncode != 0
    assert "matches none of the peers" in result.stderr

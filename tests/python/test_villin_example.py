"""Smoke test of examples/villin: --quick runs every peer on OpenMM's villin-in-water system (8,867 atoms, amber14,
PME, X-H bonds constrained), exits 0 and writes its JSON (the keys the README's table reads) and PNG.  The FLAVOR
peer of --quick freezes the bonds and the angles: the protein's frozen set is one cluster of ~1,400 coupled
distances, which must be held from the first step on.  No timing is checked."""
import json
import math
import os

import pytest

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "villin", "villin.py")


@pytest.mark.long
def test_quick_run_writes_json_and_png(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "villin.png").stat().st_size > 0
    with open(tmp_path / "villin.json") as f:
        data = json.load(f)
    assert data["atoms"] == 8867 and data["quick"]
    names = [peer["name"] for peer in data["peers"]]
    assert names[:2] == ["LangevinMiddle 2 fs", "MTSLangevin 4 fs / 4"]
    assert any(name.startswith("FLAVOR ArtificialProjected") for name in names)
    assert any("bonds+angles" in name for name in names)
    for peer in data["peers"]:
        assert peer["stable"], peer
        for key in ("ns_per_day_1_thread", "ns_per_day_2_threads", "T", "T_protein", "bond_rms all",
                    "angle_rms all", "angle_rms with H", "angle_rms heavy atoms", "backbone_rmsd"):
            assert math.isfinite(peer[key]), (peer["name"], key)
        assert 0 < peer["bond_rms all"] < 0.01 and 0 < peer["angle_rms all"] < 20


@pytest.mark.long
def test_a_middle_placement_peer_runs_and_a_bad_flavor_flag_is_an_error(tmp_path):
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--flavors", "3:0.5:middle"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "villin.json") as f:
        peers = json.load(f)["peers"]
    assert peers[-1]["name"] == "FLAVOR ArtificialProjected bonds+angles Middle δ=3 fs τ=0.5 fs"
    assert peers[-1]["stable"]
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--flavors", "2.5:1:planar"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "villin.json") as f:
        data = json.load(f)
    assert data["peers"][-1]["name"] == "FLAVOR ArtificialProjected bonds+nonplanar angles δ=2.5 fs τ=1 fs"
    assert data["peers"][-1]["stable"]
    # Every angle counted once in the observables: the separated planar ones are not counted twice.
    assert data["angles"] == 1067
    conftest.assert_cli_rejects(SCRIPT, tmp_path, ("--flavors", "2.5:1:planar:bonds"),
                                "'2.5:1:planar:bonds' is not delta:tau[:bonds|:planar][:middle]")
    conftest.assert_cli_rejects(SCRIPT, tmp_path, ("--flavors", "3:0.5:sideways"),
                                "'3:0.5:sideways' is not delta:tau[:bonds|:planar][:middle]")


@pytest.mark.long
def test_a_small_step_langevin_peer_runs_and_a_step_out_of_range_is_an_error(tmp_path):
    # With hydrogen mass repartitioning peers too (createSystem's hydrogenMass), all timed interleaved against
    # LangevinMiddle 4 fs HMR 1.5 amu.
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--flavors", "3:1:planar:middle:hmr3", "--langevin-steps",
                                                         "1", "--hmr-langevin", "4:1.5"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "villin.json") as f:
        data = json.load(f)
    names = [peer["name"] for peer in data["peers"]]
    assert names == ["LangevinMiddle 2 fs", "MTSLangevin 4 fs / 4", "LangevinMiddle 1 fs",
                     "LangevinMiddle 4 fs HMR 1.5 amu",
                     "FLAVOR ArtificialProjected bonds+nonplanar angles Middle HMR 3 amu δ=3 fs τ=1 fs"]
    assert [peer["hydrogen_mass_amu"] for peer in data["peers"]] == [None, None, None, 1.5, 3.0]
    assert data["interleaved_baseline"] == "LangevinMiddle 4 fs HMR 1.5 amu"
    for peer in data["peers"]:
        assert peer["stable"], peer
        assert peer["ns_per_day_interleaved"] > 0 and peer["interleaved_ratio"] > 0, peer["name"]
        # The kinetic temperature counts the peer's own masses: a repartitioned system is not 1.5-3x off.
        assert 100 < peer["T"] < 500, (peer["name"], peer["T"])
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--langevin-steps", "0.5", "0"))
    assert result.returncode != 0
    assert "--langevin-steps: every step must be in (0, 4] fs, got [0.5, 0.0]" in result.stderr
    for bad in (("--hmr-langevin", "4"), ("--hmr-langevin", "4:1.5:sideways"), ("--flavors", "4:1:water"),
                ("--flavors", "4:1:hmr3:hmr1.5")):
        result = conftest.run_quick(SCRIPT, tmp_path, extra=bad)
        assert result.returncode != 0, bad
        assert "is not" in result.stderr, (bad, result.stderr[-500:])

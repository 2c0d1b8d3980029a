"""flavorbench.interleaved: every peer steps the same simulated time each round, a peer that fails drops out with its
failure recorded, and the ratios are read against the first peer; the scenes' --interleaved-timing writes them, and
--wall-cost times single steps with the wall and without it."""
import json
import os

import conftest
import openmm
import pytest
from flavorbench.interleaved import interleaved_ns_per_day

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def oscillator_peer(name, step_fs):
    system = openmm.System()
    system.addParticle(1.0)
    spring = openmm.HarmonicBondForce()
    system.addParticle(1.0)
    spring.addBond(0, 1, 0.1, 1000.0)
    system.addForce(spring)
    integrator = openmm.VerletIntegrator(step_fs * 1e-3)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions([(0, 0, 0), (0.12, 0, 0)])
    return name, step_fs, integrator, context


def drude_beyond_its_wall_peer(name):
    """DrudeLangevinIntegrator with a 0.02-nm hard wall on a Drude particle 0.1 nm from its core: its first step
    raises OpenMM's "moved too far beyond hard wall constraint"."""
    system = openmm.System()
    system.addParticle(15.6)
    system.addParticle(0.4)
    drude = openmm.DrudeForce()
    drude.addParticle(1, 0, -1, -1, -1, -1.0, 0.001, 1.0, 1.0)
    system.addForce(drude)
    integrator = openmm.DrudeLangevinIntegrator(300, 5, 1, 20, 0.001)
    integrator.setMaxDrudeDistance(0.02)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions([(0, 0, 0), (0.1, 0, 0)])
    return name, 1.0, integrator, context


def test_every_peer_steps_the_warmup_and_each_rounds_simulated_time():
    peers = [oscillator_peer("one", 1.0), oscillator_peer("two and a half", 2.5)]
    lines = []
    timing = interleaved_ns_per_day(peers, rounds=3, round_ps=0.05, report=lines.append)
    for name, step_fs, _, context in peers:
        steps = 10 + 3 * round(50 / step_fs)
        assert context.getState().getTime().value_in_unit(openmm.unit.femtosecond) == pytest.approx(steps * step_fs)
        assert len(timing["ns_per_day"][name]) == 3 and min(timing["ns_per_day"][name]) > 0
    assert list(timing["median_ratio_to_first"]) == ["two and a half"]
    assert timing["median_ratio_to_first"]["two and a half"] > 0
    assert timing["failed"] == {}
    assert [line.split(":")[0] for line in lines] == ["round 1/3", "round 2/3", "round 3/3"]


def test_a_peer_that_raises_drops_out_with_its_failure_and_leaves_the_others_timed():
    peers = [oscillator_peer("baseline", 1.0), drude_beyond_its_wall_peer("walled"), oscillator_peer("other", 2.0)]
    timing = interleaved_ns_per_day(peers, rounds=2, round_ps=0.02, report=lambda line: None)
    assert list(timing["failed"]) == ["walled"]
    assert timing["failed"]["walled"]["failed_in_steps"] == [1, 10]
    assert "hard wall" in timing["failed"]["walled"]["error"]
    assert "walled" not in timing["ns_per_day"] and "walled" not in timing["median_ratio_to_first"]
    assert list(timing["median_ratio_to_first"]) == ["other"]


def test_without_the_first_peer_no_ratio_is_read():
    peers = [drude_beyond_its_wall_peer("walled"), oscillator_peer("other", 2.0)]
    timing = interleaved_ns_per_day(peers, rounds=1, round_ps=0.02, report=lambda line: None)
    assert timing["median_ratio_to_first"] == {} and len(timing["ns_per_day"]["other"]) == 1


@pytest.mark.parametrize("rounds, round_ps, message", [(0, 0.1, "rounds must be at least 1 (got 0)"),
                                                        (1, 0.0, "round_ps must be positive (got 0.0)")])
def test_no_round_or_no_time_is_rejected(rounds, round_ps, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        interleaved_ns_per_day([oscillator_peer("one", 1.0)], rounds, round_ps)


@pytest.mark.parametrize("scene, extra, peers", [
    ("drude_ions", ("--wall", "0.02", "--sim-steps", "2"), ["DrudeLangevin 1 fs", "WarpedMiddle 2 fs"]),
    ("drude_protein", ("--sim-steps", "2", "2.5", "--max-warped-phase", "1.77", "--scaled-friction"),
     ["DrudeLangevin 1 fs", "WarpedMiddle 2 fs", "WarpedMiddle 2.5 fs"]),
])
@pytest.mark.long
def test_the_drude_scenes_time_their_peers_interleaved(tmp_path, scene, extra, peers):
    script = os.path.join(REPO_ROOT, "examples", scene, scene + ".py")
    result = conftest.run_quick(script, tmp_path, extra=("--interleaved-timing", "2", "--round-ps", "0.01", *extra))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "interleaved_timing.json") as f:
        timing = json.load(f)
    assert list(timing["ns_per_day"]) == peers and timing["failed"] == {}
    assert list(timing["median_ratio_to_first"]) == peers[1:]
    assert timing["wall_nm"] == 0.02 and timing["ps_per_round"] == 0.01
    assert timing["scaled_friction"] == ("--scaled-friction" in extra)


@pytest.mark.parametrize("scene", ["drude_ions", "drude_protein"])
def test_the_drude_scenes_reject_a_timing_without_rounds(tmp_path, scene):
    script = os.path.join(REPO_ROOT, "examples", scene, scene + ".py")
    conftest.assert_cli_rejects(script, tmp_path, ("--interleaved-timing", "0"),
                                "--interleaved-timing needs at least 1 round (got 0)")


@pytest.mark.long
@pytest.mark.parametrize("scene", ["drude_ions", "drude_protein"])
def test_the_drude_scenes_time_single_steps_with_and_without_the_wall(tmp_path, scene):
    script = os.path.join(REPO_ROOT, "examples", scene, scene + ".py")
    result = conftest.run_quick(script, tmp_path, extra=("--wall-cost", "4", "--wall", "0.02", "--sim-steps", "2"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "wall_cost.json") as f:
        cost = json.load(f)
    assert cost["steps"] == 4
    assert list(cost["runs"]) == ["WarpedMiddle 2 fs, wall 0.02 nm", "WarpedMiddle 2 fs, wall 0 nm"]
    for run in cost["runs"].values():
        assert run["median_ms"] > 0 and run["mean_ms"] > 0 and 0 <= run["slow_fraction"] <= 1


@pytest.mark.parametrize("scene", ["drude_ions", "drude_protein"])
def test_the_drude_scenes_reject_a_wall_cost_without_a_wall(tmp_path, scene):
    script = os.path.join(REPO_ROOT, "examples", scene, scene + ".py")
    conftest.assert_cli_rejects(script, tmp_path, ("--wall-cost", "4", "--wall", "0"),
                                "--wall-cost needs at least 1 step and a --wall (got 4 steps, wall 0.0)")

"""Smoke tests of the Langevin example scenes (examples/langevin_slow_noise, examples/langevin_fast_noise): each runs
with --quick and writes its JSON; and the fast-noise scene's CustomIntegrator cross-checks are checked against its
FlavorIntegrator runs (friction on every copy's y via setFrictionParticles) where both give the same flow."""
import importlib.util
import json
import os

import numpy as np
import openmm
import pytest

import conftest


REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = os.path.join(REPO_ROOT, "examples")
KEYS = {"scene", "platform", "model", "parameters", "quantities", "runs", "equilibrium", "comparison", "series"}


def run_quick(script, out):
    return conftest.run_quick(os.path.join(EXAMPLES, script), out)


@pytest.mark.parametrize("scene, runs", [
    ("langevin_slow_noise", {"gla", "flavor_d0.01_t0.001", "flavor_d0.01_t0.0001"}),
    ("langevin_fast_noise", {"gla", "gla_custom", "flavor_d0.01_t0.0001", "flavor_custom_d0.01_t0.0001",
                             "flavor_d0.01_t1e-05", "flavor_custom_d0.01_t1e-05"}),
])
def test_quick_run_writes_json(tmp_path, scene, runs):
    result = run_quick(os.path.join(scene, scene + ".py"), tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / f"{scene}.json") as f:
        data = json.load(f)
    assert KEYS <= set(data)
    assert set(data["runs"]) == runs
    assert set(data["comparison"]) == runs - {"gla"}
    for comparison in data["comparison"].values():
        assert set(comparison) == set(data["quantities"])
        for entry in comparison.values():
            assert {"all", "late", "agree"} <= set(entry)
    for run in data["runs"].values():
        assert run["wall_s"] > 0 and run["copies_used"] >= 1
    assert (tmp_path / f"{scene}.png").stat().st_size > 0
    if scene == "langevin_slow_noise":
        assert (tmp_path / f"{scene}_moments.png").stat().st_size > 0
    if scene == "langevin_fast_noise":
        assert set(data["cross_check"]) == {key for key in runs if "custom" in key}


def load_fast_noise():
    path = os.path.join(EXAMPLES, "langevin_fast_noise", "langevin_fast_noise.py")
    spec = importlib.util.spec_from_file_location("langevin_fast_noise", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def trajectory(module, integrator, n, steps):
    system = module.build_system(n, 30.0)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    rng = np.random.default_rng(5)
    context.setPositions([openmm.Vec3(*p) for p in rng.normal(0.0, 0.05, (2 * n, 3))])
    context.setVelocities([openmm.Vec3(*v) for v in rng.normal(0.0, 1.0, (2 * n, 3))])
    integrator.step(steps)
    state = context.getState(getPositions=True, getVelocities=True)
    return (np.array(state.getPositions(asNumpy=True)._value), np.array(state.getVelocities(asNumpy=True)._value))


@pytest.mark.parametrize("friction", [0.0, 50.0])
@pytest.mark.parametrize("delta, tau", [(1e-3, 1e-3), (1e-2, 1e-3)])
def test_custom_schemes_match_flavor_integrator(delta, tau, friction):
    """At T = 0 (no noise) the scene's CustomIntegrator GLA and FLAVOR are its FlavorIntegrator runs: the same
    deterministic flow, friction on y only, x undamped."""
    module = load_fast_noise()
    n, steps = 3, 200
    reference = module.flavor_integrator(n, delta, tau, 0.0, friction, tau < delta, 1)
    assert reference.getFrictionParticles() == [0, 2, 4]
    expected = trajectory(module, reference, n, steps)
    custom = (module.custom_gla(n, delta, 0.0, friction, 1) if tau == delta else
              module.custom_flavor(n, delta, tau, 0.0, friction, 1))
    actual = trajectory(module, custom, n, steps)
    for a, e in zip(actual, expected):
        assert np.max(np.abs(a - e)) <= 1e-10 * max(1.0, np.max(np.abs(e)))

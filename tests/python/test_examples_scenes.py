"""Smoke tests of the deterministic FLAVOR example scenes (examples/nonlinear_stiff_soft, examples/primitive_md_2d,
examples/propane_clipper): each runs with --quick, exits 0 and writes its JSON and PNG."""
import importlib.util
import json
import math
import os

import pytest

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = os.path.join(REPO_ROOT, "examples")
KEYS = {"scene", "platform", "parameters", "runs", "slow_error", "flavor_vs_effective", "fast", "energy", "predicted",
        "series"}
RUNS = {"reference", "reference_check", "legacy", "flavor", "flavor_verlet", "effective", "flavor_r2",
        "flavor_verlet_r2"}


def run_quick(script, out):
    return conftest.run_quick(os.path.join(EXAMPLES, script), out)


@pytest.mark.parametrize("scene, slow", [
    ("nonlinear_stiff_soft", {"x", "p_x"}),
    ("primitive_md_2d", {"theta", "L"}),
    ("propane_clipper", {"theta", "phi"}),
])
def test_quick_run_writes_json(tmp_path, scene, slow):
    result = run_quick(os.path.join(scene, scene + ".py"), tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / f"{scene}.json") as f:
        data = json.load(f)
    assert KEYS <= set(data)
    assert set(data["runs"]) == RUNS
    for run in data["runs"].values():
        assert run["steps"] > 0 and run["wall_s"] > 0 and run["speedup_vs_legacy"] > 0
    assert set(data["slow_error"]) == RUNS - {"reference_check"}
    for errors in data["slow_error"].values():
        assert set(errors) == slow
        assert all(math.isfinite(e["max"]) for e in errors.values())
    assert {k for k in RUNS if k.startswith("flavor")} == set(data["flavor_vs_effective"])
    # The fast motion of a FLAVOR is the true one slowed down by sqrt(tau/delta); the quick runs are short, so only
    # a loose check that the runs are what they claim to be.
    predicted = data["predicted"]["fast_period_ratio"]
    for key in ("flavor", "flavor_verlet", "effective"):
        assert abs(data["fast"][key]["period_ratio_to_reference"] / predicted - 1) < 0.15
    assert (tmp_path / f"{scene}.png").stat().st_size > 0
    assert (tmp_path / f"{scene}_energy_error.png").stat().st_size > 0


def load_scene_module(scene):
    path = os.path.join(EXAMPLES, scene, scene + ".py")
    spec = importlib.util.spec_from_file_location(scene, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def composition(scheme, delta, tau):
    """The FLAVOR step written out as an OpenMM CustomIntegrator (f: all groups, f0: the soft group 0)."""
    import openmm
    ci = openmm.CustomIntegrator(delta)
    ci.addGlobalVariable("tau", tau)
    ci.addGlobalVariable("rest", delta - tau)
    if scheme == "SymplecticEuler":  # eq. (2.17)
        steps = [("v", "v+tau*f/m"), ("x", "x+tau*v"), ("v", "v+rest*f0/m"), ("x", "x+rest*v")]
    else:
        steps = [("v", "v+0.5*tau*f/m"), ("x", "x+0.5*tau*v"), ("v", "v+0.5*rest*f0/m"), ("x", "x+rest*v"),
                 ("v", "v+0.5*rest*f0/m"), ("x", "x+0.5*tau*v"), ("v", "v+0.5*tau*f/m")]
    for var, expr in steps:
        ci.addComputePerDof(var, expr)
    return ci


@pytest.mark.parametrize("scheme", ["SymplecticEuler", "Verlet"])
def test_scene_flavor_is_its_flow_composition(scheme):
    """On the nonlinear 2-D scene (6.8), the FLAVOR the scenes run is the composition of flows it claims to be."""
    import numpy as np
    import openmm
    from flavorbench.runners import flavor
    module = load_scene_module("primitive_md_2d")
    sc = module.PrimitiveMD2D(500.0, 1.0, 1.1, 0.8)
    results = []
    for integrator in (flavor(0.01, 2e-4, scheme), composition(scheme, 0.01, 2e-4)):
        context = openmm.Context(sc.system(1.0), integrator, openmm.Platform.getPlatformByName("Reference"))
        context.setPositions(sc.positions)
        context.setVelocities([openmm.Vec3(0, 0, 0)])
        integrator.step(500)
        state = context.getState(getPositions=True, getVelocities=True)
        results.append((np.array(state.getPositions(asNumpy=True)._value),
                        np.array(state.getVelocities(asNumpy=True)._value)))
    for a, b in zip(*results):
        assert np.max(np.abs(a - b)) <= 1e-10 * max(1.0, np.max(np.abs(b)))

"""A smoke test of a build against any OpenMM (CI runs it alone against Debian's OpenMM 7.7, after that build's C++
tests): the package imports and registers its kernels, both integrators step a small molecule on every platform OpenMM
has, and a script of the README runs."""
import os
import subprocess
import sys

import numpy as np
import openmm
import openmm.unit as unit
import pytest

from openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator

import conftest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.parametrize("platform", conftest.PLATFORMS)
@pytest.mark.parametrize("make", [lambda: FlavorIntegrator(0.02, 0.002, {1}),
                                  lambda: StochasticImpulseIntegrator(300.0, 1.0, 0.02, {1})],
                         ids=["FlavorIntegrator", "StochasticImpulseIntegrator"])
def test_both_integrators_step_the_fpu_chain(platform, make):
    integrator = make()
    context = openmm.Context(conftest.build_fpu_system(), integrator, openmm.Platform.getPlatformByName(platform))
    context.setPositions(conftest.fpu_positions())
    integrator.step(10)
    assert context.getState().getTime().value_in_unit(unit.picosecond) == pytest.approx(0.2)
    positions = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)
    assert np.all(np.isfinite(positions)) and not np.allclose(positions[:, 0], conftest.INITIAL_X)


def test_a_readme_script_runs():
    result = subprocess.run([sys.executable, os.path.join(REPO_ROOT, "examples", "scripts", "drude_water.py"),
                             "--quick"], capture_output=True, text=True, encoding="utf-8", timeout=600, cwd=REPO_ROOT)
    assert result.returncode == 0, result.stderr[-3000:]

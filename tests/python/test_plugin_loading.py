"""Importing openmmflavors registers the kernels on Reference and CPU whatever OPENMM_PLUGIN_DIR says."""
import os
import subprocess
import sys

import pytest

SCRIPT = """
import openmm, openmmflavors
system = openmm.System()
system.addParticle(1.0)
force = openmm.CustomExternalForce("0.5*100*x^2")
force.addParticle(0, [])
force.setForceGroup(1)
system.addForce(force)
soft = openmm.CustomExternalForce("0")  # FLAVOR needs a soft force; a zero one keeps the exact solution
soft.addParticle(0, [])
system.addForce(soft)
for platform in ("Reference", "CPU"):
    for integrator in (openmmflavors.FlavorIntegrator(0.01, 0.01, {1}),
                       openmmflavors.StochasticImpulseIntegrator(0, 0, 0.01, {1})):
        context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName(platform))
        context.setPositions([(0.1, 0, 0)])
        integrator.step(5)
        x = context.getState(getPositions=True).getPositions()[0][0]._value
        assert abs(x - 0.1 * __import__("math").cos(10 * 0.05)) < 1e-3, (platform, type(integrator), x)
print("ok")
"""


@pytest.mark.parametrize("plugin_dir", [None, "/nonexistent", "empty"])
def test_kernels_load_whatever_the_plugin_directory(plugin_dir, tmp_path):
    env = dict(os.environ)
    env.pop("OPENMM_PLUGIN_DIR", None)
    if plugin_dir is not None:
        env["OPENMM_PLUGIN_DIR"] = str(tmp_path) if plugin_dir == "empty" else plugin_dir
    result = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, encoding="utf-8", timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().endswith("ok")

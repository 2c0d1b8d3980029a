"""`pip install .` into a fresh virtual environment that holds OpenMM 8.6 from PyPI builds the plugin against that
OpenMM and installs it as OpenMM's published plugins are installed: the kernel plugins in OpenMM's own plugin folder
(site-packages/OpenMM.libs/lib/plugins, which `import openmm` loads), the package openmmflavors beside openmm.  Then,
with no PYTHONPATH, `import openmmflavors` works and both integrators step on every platform OpenMM has.

Skipped where the OpenMM under test is not a PyPI wheel (Debian's 7.7: pyproject.toml builds for OpenMM 8.6).  It
builds the whole plugin (a few minutes on 2 cores) and reaches PyPI through pip's cache."""
import os
import subprocess
import sys

import openmm
import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
REQUIREMENTS = os.path.join(ROOT, "requirements.txt")

pytestmark = pytest.mark.skipif(not openmm.__version__.startswith("8.6"),
                                reason=f"pyproject.toml builds for OpenMM 8.6 from PyPI; this is {openmm.__version__}")

CHECK = r"""
import os
import openmm
import openmmflavors
from openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator

libs = os.path.join(os.path.dirname(openmm.version.openmm_library_path), "lib")
plugins = os.path.join(openmm.version.openmm_library_path, "plugins")
print("plugins:", sorted(name for name in os.listdir(plugins) if "Flavors" in name))
print("failures:", [f for f in openmm.Platform.getPluginLoadFailures() if "Flavors" in f])
system = openmm.System()
for _ in range(4):
    system.addParticle(1.0)
stiff = openmm.HarmonicBondForce()
stiff.addBond(0, 1, 0.0, 1e5)  # quadratic, as the SIM needs
stiff.addBond(2, 3, 0.0, 1e5)
stiff.setForceGroup(1)
soft = openmm.HarmonicBondForce()
soft.addBond(1, 2, 0.3, 100.0)
system.addForce(stiff)
system.addForce(soft)
positions = [openmm.Vec3(0.1 * i + 0.01 * (i % 2), 0, 0) for i in range(4)]
for name in [openmm.Platform.getPlatform(i).getName() for i in range(openmm.Platform.getNumPlatforms())]:
    for integrator in (FlavorIntegrator(0.002, 0.0005, {1}), StochasticImpulseIntegrator(300.0, 1.0, 0.002, {1})):
        context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName(name))
        context.setPositions(positions)
        integrator.step(10)
        print("stepped:", name, type(integrator).__name__, context.getState().getTime())
"""


def run(command, **kwargs):
    result = subprocess.run(command, capture_output=True, text=True, encoding="utf-8", **kwargs)
    assert result.returncode == 0, f"{' '.join(command)}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


def test_pip_install_into_a_fresh_environment_with_openmm_from_pypi(tmp_path):
    venv = tmp_path / "venv"
    run(["/usr/bin/python3", "-m", "venv", str(venv)])
    python = str(venv / "bin" / "python")
    openmm_pin = next(line.strip() for line in open(REQUIREMENTS) if line.startswith("openmm=="))
    environment = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH", "LD_PRELOAD")}
    environment["CMAKE_BUILD_PARALLEL_LEVEL"] = str(os.cpu_count() or 2)
    run([python, "-m", "pip", "install", "-q", "--disable-pip-version-check", openmm_pin], env=environment)
    run([python, "-m", "pip", "install", "-q", "--disable-pip-version-check", ROOT], env=environment, timeout=1200)
    result = run([python, "-c", CHECK], env=environment, cwd=str(tmp_path))
    lines = result.stdout.splitlines()
    assert "plugins: ['libOpenMMFlavorsCPU.so', 'libOpenMMFlavorsOpenCL.so', 'libOpenMMFlavorsReference.so']" in lines \
        or "plugins: ['libOpenMMFlavorsCPU.so', 'libOpenMMFlavorsReference.so']" in lines, result.stdout
    assert "failures: []" in lines, result.stdout
    stepped = [line for line in lines if line.startswith("stepped:")]
    for platform in ("Reference", "CPU"):
        for name in ("FlavorIntegrator", "StochasticImpulseIntegrator"):
            assert any(line.startswith(f"stepped: {platform} {name} 0.02") for line in stepped), result.stdout

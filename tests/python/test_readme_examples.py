"""The README's examples run as written: the four scripts of examples/scripts (any the README shows, shown as they
are), and the C++ program of docs/USER_GUIDE.md compiled against `make install`'s prefix.  The installed Python
package holds no copy of the libraries and finds them, and the kernel plugins, in PREFIX/lib and PREFIX/lib/plugins."""
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import openmm
import pytest

import openmmflavors

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUILD_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(openmmflavors.__file__))))
LIBRARIES = ["libOpenMMFlavors.so", "libOpenMMFlavorsEngine.so", "libOpenMMFlavorsReference.so",
             "libOpenMMFlavorsCPU.so"]


SCRIPTS = ["protein", "flexible_water", "drude_water", "drude_peptide"]


def run_script(name, *arguments):
    """examples/scripts/<name>.py (--quick unless arguments are given), run as the README says (from the repository
    root); its stdout."""
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(openmmflavors.__file__)))
    env = dict(os.environ, PYTHONPATH=package_parent, PYTHONDONTWRITEBYTECODE="1")
    result = subprocess.run([sys.executable, os.path.join("examples", "scripts", name + ".py"),
                             *(arguments or ["--quick"])],
                            capture_output=True, text=True, encoding="utf-8", timeout=300, env=env, cwd=REPO_ROOT)
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def test_readme_shows_each_script_as_it_is():
    """A Python block of README.md that names examples/scripts/<name>.py in its usage line is that script, unchanged."""
    readme = open(os.path.join(REPO_ROOT, "README.md"), encoding="utf-8").read()
    blocks = re.findall(r"```python\n(.*?)```", readme, re.S)
    for name in SCRIPTS:
        with open(os.path.join(REPO_ROOT, "examples", "scripts", name + ".py"), encoding="utf-8") as f:
            script = f.read()
        for block in blocks:
            if f"examples/scripts/{name}.py" in block:
                assert block == script, f"README.md does not show examples/scripts/{name}.py as it is"


def reporter_rows(stdout):
    """The rows of StateDataReporter's CSV output: time (ps), potential energy, temperature, speed."""
    return [[float(x) for x in line.split(",")[:3]] for line in stdout.splitlines() if re.match(r"^\d+\.\d+,", line)]


def test_protein_script_leaves_the_planar_angles_soft_and_runs():
    stdout = run_script("protein")
    assert "357 angles at planar centres left soft" in stdout, stdout
    rows = reporter_rows(stdout)
    assert len(rows) == 10, stdout
    assert rows[-1][0] == pytest.approx(0.1)  # 20 equilibration and 20 reported mesosteps of 2.5 fs
    for _, energy, temperature in rows:
        assert energy < 0 and 0 < temperature < 1000, stdout


def test_flexible_water_script_keeps_the_o_h_bonds():
    stdout = run_script("flexible_water")
    rows = reporter_rows(stdout)
    assert len(rows) == 10 and rows[-1][0] == pytest.approx(0.24), stdout  # 20 + 20 mesosteps of 6 fs
    assert all(0 < temperature < 1000 for _, _, temperature in rows), stdout
    # The frozen (not weakened) bonds keep flexible TIP3P's mean O-H length, 0.0973 nm with a spread of 0.0024 nm; a
    # FLAVOR that weakens the bonds by tau/delta stretches them to 0.104 nm.
    bond = float(re.search(r"mean O-H length ([0-9.]+) nm", stdout).group(1))
    assert 0.095 < bond < 0.1, stdout


def test_drude_water_script_keeps_the_drudes_cold():
    stdout = run_script("drude_water")
    omega = float(re.search(r"stiffest Drude mode (\d+)/ps", stdout).group(1))
    assert 1000 < omega < 1100, stdout  # SWM4-NDP's Drude spring: 1036/ps
    rows = [[float(x) for x in line.split()] for line in stdout.splitlines() if re.match(r"^\s+\d+\.\d+\s", line)]
    assert len(rows) == 10 and rows[-1][0] == pytest.approx(0.1), stdout  # 20 + 20 steps of 2.5 fs
    for _, t_molecules, t_drudes, energy in rows:
        # 20 steps at the Drudes' 20/ps bath take them from 300 K to a few tens of K; the molecules stay near 300 K.
        assert 100 < t_molecules < 500 and 0 < t_drudes < 100 and energy < 0, stdout


def test_drude_peptide_script_holds_the_water_at_300_k_and_the_drudes_cold():
    """1 ps after the script's minimization and 0.5 ps at the baths (seeded). The water's kinetic temperature over
    N degrees of freedom has a standard deviation of 300 K * sqrt(2/N) at each instant; the mean of the ten reports
    has at most that (fully correlated reports), so 5 of it bounds the mean's distance from 300 K. The Drude particles'
    bath is at 1 K; DrudeLangevinIntegrator at 0.5 fs holds them at 1.61 K, the integrator at 1.49 K
    (examples/drude_protein), with a standard deviation of sqrt(2/(3 * 260)) = 5 % per instant."""
    stdout = run_script("drude_peptide", "--steps", "500", "--seed", "3")
    particles = re.search(r"(\d+) particles, (\d+) Drude pairs", stdout)
    assert particles and int(particles.group(2)) == 260, stdout  # the peptide's 10 and the water's 250
    rows = [[float(x) for x in line.split()] for line in stdout.splitlines() if re.match(r"^\s+\d+\.\d+\s", line)]
    assert len(rows) == 10 and rows[-1][0] == pytest.approx(1.5), stdout  # 250 + 500 steps of 2 fs
    water_dof = 6 * 250 - 3  # three massive bodies per rigid molecule, less the removed momentum
    t_water = np.mean([row[2] for row in rows])
    assert abs(t_water - 300) < 5 * 300 * np.sqrt(2 / water_dof), stdout
    assert all(0 < row[1] < 1000 for row in rows), stdout  # the peptide: 30 degrees of freedom or so, sd about 75 K
    t_drudes = np.mean([row[3] for row in rows])
    assert 1.49 * (1 - 5 * 0.05) < t_drudes < 1.61 * (1 + 5 * 0.05), stdout
    assert re.search(r"\d+\.\d+ ns/day", stdout), stdout


@pytest.fixture(scope="module")
def prefix(tmp_path_factory):
    prefix = tmp_path_factory.mktemp("prefix")
    result = subprocess.run(["cmake", "--install", BUILD_DIR, "--prefix", str(prefix)], capture_output=True,
                            text=True, encoding="utf-8", timeout=300)
    assert result.returncode == 0, result.stderr
    return prefix


def test_install_holds_each_library_once(prefix):
    found = {}
    for root, _, files in os.walk(prefix):
        for name in files:
            found.setdefault(name, []).append(os.path.relpath(os.path.join(root, name), prefix))
    assert found["libOpenMMFlavors.so"] == ["lib/libOpenMMFlavors.so"]
    assert found["libOpenMMFlavorsEngine.so"] == ["lib/libOpenMMFlavorsEngine.so"]
    assert found["libOpenMMFlavorsReference.so"] == ["lib/plugins/libOpenMMFlavorsReference.so"]
    assert found["libOpenMMFlavorsCPU.so"] == ["lib/plugins/libOpenMMFlavorsCPU.so"]


INSTALLED_SCRIPT = """
import openmm, openmmflavors
system = openmm.System()
system.addParticle(1.0)
stiff = openmm.CustomExternalForce("0.5*100*x^2")
stiff.addParticle(0, [])
stiff.setForceGroup(1)
system.addForce(stiff)
soft = openmm.CustomExternalForce("0")
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
print(openmmflavors.__file__)
for line in open("/proc/self/maps"):
    path = line.split()[-1]
    if "OpenMMFlavors" in path or "_openmmflavors" in path:
        print(path)
"""


def test_installed_python_package_uses_the_installed_libraries(prefix, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(prefix / "lib" / "python3" / "dist-packages"), PYTHONDONTWRITEBYTECODE="1")
    result = subprocess.run([sys.executable, "-c", INSTALLED_SCRIPT], capture_output=True, text=True, encoding="utf-8", timeout=300,
                            env=env, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    paths = set(result.stdout.split())
    assert str(prefix) in next(iter(p for p in paths if p.endswith("__init__.py")))
    for name in LIBRARIES:
        loaded = [p for p in paths if os.path.basename(p) == name]
        assert len(loaded) == 1 and loaded[0].startswith(str(prefix) + "/lib/"), (name, paths)


def test_cpp_example_compiles_and_runs_against_the_installation(prefix, tmp_path):
    compiler = shutil.which("g++")
    if compiler is None:
        pytest.fail("g++ is needed to compile the C++ example")
    program = tmp_path / "flavor_harmonic_chain"
    # The command of docs/USER_GUIDE.md, with PREFIX replaced; for an OpenMM outside the system's paths (the wheel's
    # OpenMM.libs) its include and lib folders too, and its plugin folder for the program.
    openmm_lib = openmm.version.openmm_library_path  # empty for Debian's OpenMM, which is in the system's paths
    openmm_flags, environment = [], dict(os.environ)
    if openmm_lib:
        openmm_flags = ["-I", os.path.join(os.path.dirname(openmm_lib), "include"), "-L", openmm_lib,
                        f"-Wl,-rpath,{openmm_lib}"]
        environment["OPENMM_PLUGIN_DIR"] = os.path.join(openmm_lib, "plugins")
    compile_result = subprocess.run(
        [compiler, "-std=c++17", os.path.join(REPO_ROOT, "examples", "cpp", "flavor_harmonic_chain.cpp"),
         "-I", f"{prefix}/include/openmmflavors", *openmm_flags, "-L", f"{prefix}/lib", f"-Wl,-rpath,{prefix}/lib",
         "-lOpenMMFlavors", "-lOpenMM", "-o", str(program)], capture_output=True, text=True, encoding="utf-8", timeout=600)
    assert compile_result.returncode == 0, compile_result.stderr[-3000:]
    run = subprocess.run([str(program), f"{prefix}/lib/plugins"], capture_output=True, text=True, encoding="utf-8", timeout=300,
                         env=environment)
    assert run.returncode == 0, run.stderr[-3000:]
    rows = [line.split() for line in run.stdout.splitlines() if re.match(r"^\s*\d+\.\d+\s", line)]
    assert len(rows) == 11 and float(rows[-1][0]) == pytest.approx(100.0)
    # H_eff (last column) is conserved by the FLAVOR to within a few parts in 1e4 over the run.
    h_eff = [float(row[3]) for row in rows]
    assert max(h_eff) - min(h_eff) < 1e-3 * abs(h_eff[0]), run.stdout

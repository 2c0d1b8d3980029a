"""Smoke tests of benchmarks/work_precision.py, stability.py, sim_step_cost.py, sim_work_precision.py and (where OpenMM
has a GPU platform: OpenCL, CUDA) the FPU scene of gpu_benchmark.py: each runs with --quick into a temporary folder, exits 0
and writes its JSON, markdown and charts with the expected structure.
The C++ helper benchmarks/step_cost is run once on each of its two systems.
The numbers themselves are the benchmarks' business, not the tests'; only what must hold by construction is
checked."""
import importlib.util
import json
import os
import subprocess
import sys

import conftest
import pytest
from flavorbench.helper import find_helper

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BENCHMARKS = os.path.join(REPO_ROOT, "benchmarks")
METHODS = {"verlet", "rrespa", "flavor_verlet", "flavor_euler", "sim_lietrotter", "sim_strang", "sim_yoshida4"}


def run_quick(script, out, outputs):
    """Runs a benchmark's --quick mode; checks that it succeeded and wrote the outputs; returns it and its JSON."""
    result = conftest.run_quick(os.path.join(BENCHMARKS, script), out)
    assert result.returncode == 0, result.stderr[-3000:]
    for name in outputs:
        assert (out / name).stat().st_size > 0, name
    with open(out / next(name for name in outputs if name.endswith(".json"))) as f:
        return result, json.load(f)


def test_work_precision_quick(tmp_path):
    result, data = run_quick("work_precision.py", tmp_path,
                             ("work_precision.json", "work_precision.md", "work_precision_slow.png",
                              "work_precision_stiff.png", "work_precision_cost.png"))
    case = data["cases"][0]
    assert {r["method"] for r in case["runs"]} == METHODS
    reference = case["reference"]["checkpoints"]
    for info in reference.values():
        # The reference's own error (difference of its h and 2h runs) is far below anything the table resolves.
        assert info["self_check_x0_1"] < 1e-8
    for run in case["runs"]:
        for c in run["checkpoints"].values():
            assert c["group_evals"] == c["steps"] * (run["soft_per_step"] + run["stiff_per_step"])
            if run["method"] == "verlet" and run["params"]["omega_h"] <= 0.2:
                assert c["slow_T"] < 1e-3  # a resolving Verlet run must agree with the independent reference
    assert {row["method"] for row in data["table"]} == METHODS
    assert "| omega" in result.stdout and "speedup vs Verlet" in result.stdout


def test_stability_quick(tmp_path):
    _, data = run_quick("stability.py", tmp_path, ("stability.json", "stability.png", "resonance.png"))
    domain = data["flavor_domain"]
    assert set(domain["schemes"]) == {"SymplecticEuler", "Verlet"}
    for scheme in domain["schemes"].values():
        bounded = scheme["bounded"]
        assert len(bounded) == len(domain["tau_omega2"]) and len(bounded[0]) == len(domain["deltas"])
        # Theorem 5.1 at tau*omega^2 = 1e-3: the smallest delta is stable, delta = 3 is not.
        assert bounded[0][0] == 1 and bounded[0][-1] == 0
    resonance = data["resonance"]
    n = len(resonance["omega_H"])
    assert len(resonance["rrespa"]) == n and len(resonance["sim"]) == n
    assert resonance["sim_langevin"] and all(len(v) == n for v in resonance["sim_langevin"].values())
    # Away from resonance (omega*H = 0.5) the impulse methods conserve the energy well.
    assert resonance["rrespa"][0][0] < 0.05 and resonance["sim"][0][0] < 0.05
    boundary = domain["boundary"]
    for scheme in ("SymplecticEuler", "Verlet"):
        # The runs and the exact transfer matrix find the same boundary; Theorem 5.1's delta = 2 at small tau.
        assert abs(boundary[scheme]["runs"][0] - boundary[scheme]["matrix"][0]) < 0.02
        assert 1.9 < boundary[scheme]["runs"][0] <= 2.0


def test_sim_step_cost_quick(tmp_path):
    _, data = run_quick("sim_step_cost.py", tmp_path, ("sim_step_cost.json", "sim_step_cost.png"))
    assert set(data["runs"]) == {"Strang_friction0", "LieTrotter_friction0", "Strang_friction1", "LieTrotter_friction1"}
    assert all(run["step_us"] > 0 and run["mode_work_us"] > 0 for run in data["runs"].values())
    scaling = data["component_scaling"]
    assert [r["sum_nc2"] for r in scaling["rows"]] == [scaling["particles"] * r["n_c"] for r in scaling["rows"]]
    assert all(r["step_us_friction0"] > 0 and r["step_us_friction1"] > 0 for r in scaling["rows"])


@pytest.mark.long
def test_sim_work_precision_quick(tmp_path):
    _, data = run_quick("sim_work_precision.py", tmp_path, ("sim_work_precision.json", "sim_work_precision.png"))
    criterion = data["criterion"]
    for result in data["a_work_precision"].values():
        assert {"sim_strang", "verlet"} <= set(result["methods"])
        assert set(result["speedup_sim_strang_over_verlet"]) == {"cheapest", "cheapest_x0_only",
                                                                 "cheapest_energy_scale"}
        for method in result["methods"].values():
            for run in method["runs"]:
                strict = run["rel_err_x0_1"] <= criterion["x0_1_relative"] and \
                    max(run["rel_err_I"]) <= criterion["every_I_j_relative"]
                assert run["passes"] == strict
                # Every I_j error relative to the total stiff energy at T is at most the maximum over the samples.
                at_T = max(run["abs_err_I"]) / sum(result["reference"]["I_T"])
                assert at_T <= run["energy_scale_err_I"] * (1 + 1e-12)
            best = method["cheapest_energy_scale"]
            if best is not None:
                assert best["energy_scale_err_I"] <= criterion["every_I_j_relative"]
    assert data["b_setup"]["rows"] and data["c_step_cost"]["rows"]


def test_step_cost_helper_builds_both_systems():
    helper = find_helper()
    assert helper is not None, "benchmarks/step_cost is built with the project"
    for args, particles in ((["--chains", "2"], 12), (["--springs", "50"], 100)):
        out = subprocess.run([helper, "--steps", "3"] + args + ["sim_strang", "force_soft"], capture_output=True,
                             text=True, encoding="utf-8", timeout=120)
        assert out.returncode == 0, out.stderr
        data = json.loads(out.stdout)
        assert data["particles"] == particles
        assert set(data["results"]) == {"sim_strang", "force_soft"}
        assert all(r["steps"] == 3 and r["us_per_step_min"] > 0 for r in data["results"].values())


def test_drude_step_instructions_sorts_functions_and_redraws_its_chart(tmp_path):
    # The callgrind runs need valgrind and minutes; here the sorting of functions into categories and --replot.
    spec = importlib.util.spec_from_file_location("drude_step_instructions",
                                                  os.path.join(BENCHMARKS, "drude_step_instructions.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.category("???:OpenMM::CpuNeighborList::threadComputeNeighborList(...)") == "neighbour list"
    assert module.category("???:OpenMM::ReferenceSETTLEAlgorithm::apply(...)") == "SETTLE"
    assert module.category("???:FlavorPlugin::CounterRandom::normals(...) [libOpenMMFlavorsEngine.so]") == "integrator"
    assert module.category("???:OpenMM::SimTKOpenMMUtilities::getNormallyDistributedRandomNumber()") == "integrator"
    assert module.category("???:OpenMM::pme_exec(...) [libOpenMM.so.7.7]") == "nonbonded and PME forces"
    assert module.category("./string/memmove-vec-unaligned-erms.S:__memcpy_avx_unaligned_erms") == "rest"
    runs = [{"label": label, "step_fs": h, "per_step": dict.fromkeys(module.CATEGORIES, 1e6 * h),
             "per_fs": dict.fromkeys(module.CATEGORIES, 1e6)} for label, _, h in module.RUNS]
    path = tmp_path / "data.json"
    path.write_text(json.dumps({"runs": runs}))
    result = subprocess.run([sys.executable, os.path.join(BENCHMARKS, "drude_step_instructions.py"),
                             "--out", str(tmp_path), "--replot", str(path)], capture_output=True, text=True, encoding="utf-8",
                            env=dict(os.environ, MPLBACKEND="Agg"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert (tmp_path / "drude_step_instructions.png").stat().st_size > 0


def test_callgrind_per_step_matches_functions_by_name_across_libraries(monkeypatch):
    # A set-up cost that callgrind names after another library in the long run is no per-step cost; a function
    # whose count grows is, under the long run's library.
    from flavorbench import callgrind
    grow = "???:std::vector<double>::_M_realloc_insert(double const&)"
    runs = {"short": {grow + " [/py/_openmm.so]": 500, "???:Engine::step() [libOpenMMFlavorsEngine.so]": 30,
                      "???:Setup::once() [libOpenMM.so]": 7},
            "long": {grow + " [libOpenMMFlavorsEngine.so]": 500, "???:Engine::step() [libOpenMMFlavorsEngine.so]": 90,
                     "???:operator[](int) [libOpenMMFlavorsEngine.so]": 40}}
    monkeypatch.setattr(callgrind, "per_function", lambda path: runs[path])
    steps = callgrind.per_step("short", "long", (10, 40))
    assert steps == {grow + " [libOpenMMFlavorsEngine.so]": 0.0, "???:Engine::step() [libOpenMMFlavorsEngine.so]": 2.0,
                     "???:Setup::once() [libOpenMM.so]": -7 / 30,
                     "???:operator[](int) [libOpenMMFlavorsEngine.so]": 40 / 30}


@pytest.mark.long
def test_frozen_energy_drift_quick_runs_every_peer_on_both_molecules_and_replots(tmp_path):
    result, data = run_quick("frozen_energy_drift.py", tmp_path,
                             ("frozen_energy_drift.json", "frozen_energy_drift.png"))
    assert [m["name"] for m in data["molecules"]] == ["villin", "POPC"]
    assert [m["atoms"] for m in data["molecules"]] == [582, 134]
    for molecule in data["molecules"]:
        assert [r["label"] for r in molecule["runs"]] == [
            "Verlet 0.5 fs", "FLAVOR δ=2 fs τ=1 fs", "FLAVOR δ=2.5 fs τ=1 fs", "FLAVOR δ=3 fs τ=1 fs",
            "FLAVOR δ=2 fs τ=1 fs, planar angles soft", "FLAVOR δ=2.5 fs τ=1 fs, planar angles soft",
            "FLAVOR δ=3 fs τ=1 fs, planar angles soft"]
        for r in molecule["runs"]:
            assert len(r["time_ps"]) == len(r["total_energy"]) == 3
            assert r["gain_per_atom_by_residue"]
            gains = [e for _, e in r["stiff_terms_gaining_most"]]
            assert gains == sorted(gains, reverse=True) and len(gains) == 6
            assert isinstance(r["stiff_terms_gain"], float)
    replot = conftest.run_quick(os.path.join(BENCHMARKS, "frozen_energy_drift.py"), tmp_path / "again",
                                extra=("--replot", str(tmp_path / "frozen_energy_drift.json")))
    assert replot.returncode == 0, replot.stderr[-2000:]
    assert (tmp_path / "again" / "frozen_energy_drift.png").stat().st_size > 0


def test_frozen_energy_drift_rejects_a_mesostep_not_above_the_microstep(tmp_path):
    result = conftest.run_quick(os.path.join(BENCHMARKS, "frozen_energy_drift.py"), tmp_path, extra=("--deltas", "1"))
    assert result.returncode != 0
    assert "--deltas: 1 fs is not allowed" in result.stderr


@pytest.mark.parametrize("platform", ["OpenCL", "CUDA"])
def test_gpu_benchmark_quick(tmp_path, platform):
    """The FPU scene of benchmarks/gpu_benchmark.py in double precision: every peer runs on the platform and is
    timed."""
    if platform not in conftest.GPU_PLATFORMS:
        pytest.skip(f"OpenMM has no {platform} platform here")
    result = conftest.run_quick(os.path.join(BENCHMARKS, "gpu_benchmark.py"), tmp_path, timeout=300,
                                extra=("--platform", platform, "--scenes", "fpu", "--precision", "double"))
    assert result.returncode == 0, result.stderr[-3000:]
    stem = f"gpu_benchmark_{platform.lower()}"
    assert (tmp_path / f"{stem}.png").stat().st_size > 0
    with open(tmp_path / f"{stem}.json") as f:
        data = json.load(f)
    assert data["platform"] == platform
    run = data["scenes"]["fpu"]["precisions"]["double"]
    assert run["device"]["Precision"] == "double"
    assert set(run["peers"]) == {"Verlet h=0.002", "SIM Strang H=0.002", "SIM Strang H=0.01"}
    for peer in run["peers"].values():
        assert peer["available"] and peer["ns_per_day"] > 0 and len(peer["all"]) == data["repeats"]


@pytest.mark.long
@pytest.mark.parametrize("platform", ["OpenCL", "CUDA"])
def test_gpu_benchmark_quick_runs_the_drude_2019_peptide_under_every_peer(tmp_path, platform):
    """The drude_protein scene in mixed precision (the GPU's): the Drude-2019 System (anisotropic and Thole-screened
    Drude particles, lone pairs, X-H constraints on cores with Drude particles) runs behind the hard wall under
    DrudeLangevin and under the SIM at 2, 2.5 and 3 fs, each timed in every repeat."""
    if platform not in conftest.GPU_PLATFORMS:
        pytest.skip(f"OpenMM has no {platform} platform here")
    result = conftest.run_quick(os.path.join(BENCHMARKS, "gpu_benchmark.py"), tmp_path, timeout=600,
                                extra=("--platform", platform, "--scenes", "drude_protein", "--precision", "mixed"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / f"gpu_benchmark_{platform.lower()}.json") as f:
        data = json.load(f)
    run = data["scenes"]["drude_protein"]["precisions"]["mixed"]
    assert run["device"]["Precision"] == "mixed"
    assert [peer["step_fs"] for peer in run["peers"].values()] == [1.0, 2.0, 2.5, 3.0]
    for name, peer in run["peers"].items():
        assert peer["available"] and peer["ns_per_day"] > 0 and len(peer["all"]) == data["repeats"], name

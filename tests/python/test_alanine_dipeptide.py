"""examples/alanine_dipeptide: with --quick (seeded) it exits 0, writes its JSON and PNG, every peer reports every
observable as a finite number, the basin populations add up to 100 %, and the reference's kinetic temperature is
within 5 of its standard errors of the bath's 300 K."""
import json
import math
import os
import subprocess
import sys

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "alanine_dipeptide", "alanine_dipeptide.py")
OBSERVABLES = ["pop_beta", "pop_alphaR", "pop_alphaL", "transitions_per_ns", "T_heavy", "T_H", "T_all",
               "potential_energy", "width bond heavy", "width angle heavy", "width angle withH",
               "width angle heavy nonplanar", "width angle heavy planar", "width angle withH nonplanar",
               "width angle withH planar"]


def test_alanine_dipeptide_quick(tmp_path):
    env = dict(os.environ, OPENMM_CPU_THREADS="1")
    result = subprocess.run([sys.executable, SCRIPT, "--quick", "--out", str(tmp_path)], capture_output=True,
                            text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "alanine_dipeptide.png").stat().st_size > 0
    with open(tmp_path / "alanine_dipeptide.json") as f:
        data = json.load(f)
    results = data["results"]
    assert [r["name"] for r in results] == [
        "LangevinMiddle 1 fs", "LangevinMiddle 4 fs HMR 1.5 amu", "FLAVOR HMR 3 amu δ = 4 fs, τ = 1 fs",
        "FLAVOR HMR 3 amu δ = 6 fs, τ = 1 fs", "FLAVOR HMR 3 amu δ = 8 fs, τ = 1 fs"]
    for r in results:
        assert "failed" not in r, r.get("failed")
        for key in OBSERVABLES:
            assert math.isfinite(r[key]) and math.isfinite(r[key + "_error"]), (r["name"], key)
        assert r["ns_per_day"] > 0 and math.isfinite(r["ratio_to_baseline"])
        assert abs(sum(r["pop_" + b] for b in ("beta", "alphaR", "alphaL")) - 100.0) < 1e-9
        assert r["width bond heavy"] > 0 and r["width angle heavy"] > 0
    reference = results[0]
    assert reference["T_all_error"] > 0
    assert abs(reference["T_all"] - 300.0) < 5 * reference["T_all_error"], (reference["T_all"],
                                                                             reference["T_all_error"])

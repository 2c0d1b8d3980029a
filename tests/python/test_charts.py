"""The verdict charts: benchmarks/scene_charts.py draws docs/drude_water.png and docs/villin.png from the stored
results alone; examples/fpu/fpu.py redraws its chart from its JSON (--replot); benchmarks/work_precision.py --demo,
which `make demo` runs, explains in one line the resonances its step sweeps cross instead of printing the
integrator's ResonanceWarning for each."""
import os
import subprocess
import sys

import pytest

import openmmflavors

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run(arguments, cwd):
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(openmmflavors.__file__)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [package_parent, os.environ.get("PYTHONPATH")])),
               PYTHONDONTWRITEBYTECODE="1")
    result = subprocess.run([sys.executable, *arguments], capture_output=True, text=True, encoding="utf-8",
                            timeout=600, env=env, cwd=cwd)
    assert result.returncode == 0, result.stderr[-3000:]
    return result


def test_scene_charts_are_drawn_from_the_stored_results(tmp_path):
    run([os.path.join(REPO_ROOT, "benchmarks", "scene_charts.py"), "--out", str(tmp_path)], tmp_path)
    for name in ("drude_water.png", "villin.png"):
        assert (tmp_path / name).stat().st_size > 20000, name


def test_fpu_chart_is_redrawn_from_its_json(tmp_path):
    run([os.path.join(REPO_ROOT, "examples", "fpu", "fpu.py"), "--quick", "--out", str(tmp_path / "run")], tmp_path)
    run([os.path.join(REPO_ROOT, "examples", "fpu", "fpu.py"), "--replot", str(tmp_path / "run" / "fpu.json"),
         "--out", str(tmp_path / "replot")], tmp_path)
    assert (tmp_path / "replot" / "fpu.png").stat().st_size > 20000


@pytest.mark.long  # about 25 s
def test_work_precision_demo_explains_its_resonances_in_one_line(tmp_path):
    result = run([os.path.join(REPO_ROOT, "benchmarks", "work_precision.py"), "--demo", "--out", str(tmp_path)],
                 tmp_path)
    assert "ResonanceWarning" not in result.stderr, result.stderr[-3000:]
    lines = [line for line in result.stdout.splitlines() if "resonance band" in line]
    assert len(lines) == 1 and "on purpose" in lines[0], result.stdout[-3000:]
    for name in ("work_precision_slow.png", "work_precision_stiff.png"):
        assert (tmp_path / name).stat().st_size > 20000, name

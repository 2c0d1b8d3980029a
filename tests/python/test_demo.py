"""Smoke test of examples/demo/demo.py, the first thing `make demo` runs: with --quick (small boxes, a few
femtoseconds per peer) it prints both molecular scenes, each peer's row and the full runs' numbers after them, the
full runs' numbers as docs/scene_results.json has them (one source for the demo and the README's table)."""
import json
import os
import subprocess
import sys

import openmmflavors

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_demo_quick_prints_both_scenes_with_their_peers(tmp_path):
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(openmmflavors.__file__)))
    # The package's folder first, then the caller's path (where flavorbench may live apart from the package).
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [package_parent, os.environ.get("PYTHONPATH")])),
               PYTHONDONTWRITEBYTECODE="1")
    result = subprocess.run([sys.executable, os.path.join(REPO_ROOT, "examples", "demo", "demo.py"), "--quick"],
                            capture_output=True, text=True, encoding="utf-8", timeout=300, env=env, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    out = result.stdout
    assert out.index("== 1. Polarizable water") < out.index("== 2. Flexible water"), out
    for row in ["DrudeLangevin 1 fs", "SIM Warped Middle 2.5 fs", "LangevinMiddle flexible 2 fs",
                "FLAVOR delta=6 fs tau=0.5 fs"]:
        assert "\n  " + row in out, (row, out)
    assert "failed" not in out and "Warning" not in result.stderr, (out, result.stderr[-3000:])
    assert out.count("Full runs (examples/") == 4, out
    with open(os.path.join(REPO_ROOT, "docs", "scene_results.json"), encoding="utf-8") as f:
        scenes = json.load(f)["scenes"]
    words = " ".join(out.split())  # the demo wraps its lines to the terminal's width
    for name in ("drude_water", "flexible_water", "drude_peptide", "villin"):
        speed = scenes[name]["speed"]
        assert f"speed: {'about ' if speed.get('approximate') else ''}{speed['text']} {speed['peer']} (" in words, \
            (name, out)
        assert " ".join(scenes[name]["accuracy"]["summary"].split()) in words, (name, out)

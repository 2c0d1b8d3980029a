"""Smoke test of examples/demo/demo.py, the first thing `make demo` runs: with --quick (small boxes, a few
femtoseconds per peer) it prints both molecular scenes, each peer's row and the full runs' numbers after them."""
import os
import subprocess
import sys

import openmmflavors

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_demo_quick_prints_both_scenes_with_their_peers(tmp_path):
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(openmmflavors.__file__)))
    env = dict(os.environ, PYTHONPATH=package_parent, PYTHONDONTWRITEBYTECODE="1")
    result = subprocess.run([sys.executable, os.path.join(REPO_ROOT, "examples", "demo", "demo.py"), "--quick"],
                            capture_output=True, text=True, encoding="utf-8", timeout=300, env=env, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    out = result.stdout
    assert out.index("== 1. Polarizable water") < out.index("== 2. Flexible water"), out
    for row in ["DrudeLangevin 1 fs", "SIM Warped Middle 2.5 fs", "LangevinMiddle flexible 0.5 fs",
                "LangevinMiddle flexible 2 fs", "FLAVOR delta=4 fs tau=0.5 fs"]:
        assert "\n  " + row in out, (row, out)
    assert "failed" not in out, out
    assert out.count("Full runs (examples/") == 2, out

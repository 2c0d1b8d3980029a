"""The C++ helper benchmarks/step_cost (target `step_cost`): per-step times of one force evaluation or one integrator
step without Python in the loop, and, under valgrind's callgrind, instruction counts that do not depend on the
machine's load."""
import json
import os
import re
import shutil
import subprocess
import sys

from . import _config


def find_helper(path=None):
    """The helper: `path` if given, else $FLAVORS_STEP_COST, else the one built with this package, else `step_cost`
    on the PATH; None if there is none."""
    for candidate in (path, os.environ.get("FLAVORS_STEP_COST"), _config.STEP_COST):
        if candidate and os.path.isfile(candidate) and os.access(candidate, os.X_OK):
            return candidate
    return shutil.which("step_cost")


def run_helper(helper, args, label):
    """The helper's results for `args` (its JSON "results"), or None if there is no helper or it failed."""
    if helper is None:
        return None
    print(f"  [{label}] C++ helper: {' '.join([os.path.basename(helper)] + args)}", file=sys.stderr, flush=True)
    try:
        out = subprocess.run([helper] + args, check=True, capture_output=True, text=True, timeout=300)
    except (subprocess.SubprocessError, OSError) as error:
        print(f"  [{label}] C++ helper failed: {error}", file=sys.stderr)
        return None
    return json.loads(out.stdout)["results"]


def callgrind_total(valgrind, command, options=()):
    """The instructions callgrind counts in one run of command."""
    command = [valgrind, "--tool=callgrind", "--callgrind-out-file=/dev/null"] + list(options) + command
    out = subprocess.run(command, capture_output=True, text=True, timeout=600)
    found = re.search(r"I\s+refs:\s+([\d,]+)", out.stderr)
    if out.returncode != 0 or not found:
        raise RuntimeError(f"callgrind run failed: {' '.join(command)}\n{out.stderr[-2000:]}")
    return int(found.group(1).replace(",", ""))


def count_instructions(helper, valgrind, args, name, steps):
    """Instructions per step of one helper measurement: the difference of two callgrind runs, so setup cancels."""
    totals = [callgrind_total(valgrind, [helper] + args + ["--steps", str(n), name]) for n in steps]
    return (totals[1] - totals[0]) / (steps[1] - steps[0])


def count_instructions_inside(helper, valgrind, args, name, function):
    """Instructions spent inside one function (and everything it calls) in a helper run of one step: callgrind
    collects only while the function runs."""
    return callgrind_total(valgrind, [helper] + args + ["--steps", "1", name], [f"--toggle-collect={function}"])

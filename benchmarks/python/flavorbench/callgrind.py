"""Instruction counts from valgrind's callgrind: load-independent, unlike wall times on a shared machine."""
import importlib.util
import os
import re
import shutil
import subprocess

from . import _config


def require_valgrind(parser):
    """The valgrind executable; a parser error when valgrind or callgrind_annotate is missing."""
    valgrind = shutil.which("valgrind")
    if valgrind is None or shutil.which("callgrind_annotate") is None:
        parser.error("valgrind and callgrind_annotate are needed (apt-get install valgrind)")
    return valgrind


def per_function(path):
    """Self instructions of every function in one callgrind output file."""
    out = subprocess.run(["callgrind_annotate", "--inclusive=no", "--threshold=100", path], capture_output=True,
                         text=True, check=True).stdout
    counts = {}
    for line in out.splitlines():
        match = re.match(r"^\s*([\d,]+)\s+\([^)]*\)\s+(.*)$", line)
        if match and "PROGRAM TOTALS" not in match.group(2):
            counts[match.group(2)] = counts.get(match.group(2), 0) + int(match.group(1).replace(",", ""))
    return counts


def per_step(short_path, long_path, steps):
    """Per function, the instructions of one step: the difference of a long and a short run over their step counts.

    Functions are matched by name alone: callgrind names a template instantiated in several libraries (a
    std::vector's growth, say) after whichever library it met first, which may differ between the two runs, and a
    set-up cost would then read as a per-step one.  Each function keeps the library the long run names."""
    short, long_ = _by_name(per_function(short_path)), _by_name(per_function(long_path))
    return {name + long_.get(name, short.get(name))[1]: (long_.get(name, (0, ""))[0] - short.get(name, (0, ""))[0]) /
            (steps[1] - steps[0]) for name in set(short) | set(long_)}


def _by_name(counts):
    """{"function [library]": count} -> {"function": (count summed over libraries, " [library]")}."""
    merged = {}
    for key, count in counts.items():
        match = re.match(r"^(.*?)( \[[^\]]*\])?$", key)
        name, library = match.group(1), match.group(2) or ""
        total, named = merged.get(name, (0, library))
        merged[name] = (total + count, named or library)
    return merged


def scene_module(name):
    """The script examples/<name>/<name>.py of the source tree as a module (its functions build the scene)."""
    path = os.path.join(_config.SOURCE_DIR, "examples", name, name + ".py")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module

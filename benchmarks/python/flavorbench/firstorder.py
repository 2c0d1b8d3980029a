"""The C++ programs of the first-order scenes (examples/van_der_pol, examples/hidden_sde): each run of a FirstOrderFlavor
is one call of the scene's program, which writes its results as JSON on stdout and its progress on stderr."""
import json
import os
import subprocess
import sys

from . import _config, reporting

PROGRAMS = {"van_der_pol": ("FLAVORS_VAN_DER_POL", _config.VAN_DER_POL),
            "hidden_sde": ("FLAVORS_HIDDEN_SDE", _config.HIDDEN_SDE)}


def program(name):
    """The path of the scene's program: $FLAVORS_VAN_DER_POL / $FLAVORS_HIDDEN_SDE, else the one built with this
    package."""
    variable, built = PROGRAMS[name]
    path = os.environ.get(variable) or built
    if not (path and os.path.isfile(path) and os.access(path, os.X_OK)):
        sys.exit(f"{name}: the program {path or name} is missing: build the project (make build) or set ${variable}")
    return path


def run(name, **options):
    """One run: `program --option value ...`; its JSON output as a dict.  Progress lines go to stderr as they come."""
    command = [program(name)] + [str(item) for key, value in options.items() for item in (f"--{key}", value)]
    print(f"  {name} {' '.join(command[1:])}", file=sys.stderr, flush=True)
    result = subprocess.run(command, stdout=subprocess.PIPE, text=True)
    if result.returncode != 0:
        sys.exit(f"{name} failed (exit {result.returncode}): {' '.join(command)}")
    return json.loads(result.stdout)


def add_chart_arguments(parser):
    """--docs and --replot, as both scenes have them."""
    parser.add_argument("--docs", default=None, help="also write a small copy of the chart to this directory")
    parser.add_argument("--replot", metavar="JSON", help="only redraw the chart of an earlier run's JSON into --out")


def replot(args, name, plot):
    """With --replot, redraw <out>/<name>.png (and the --docs copy) from the JSON with plot(data, path, small) and
    return True; otherwise return False."""
    if not args.replot:
        return False
    reporting.replot(args.replot, args.out, name, plot)
    if args.docs:
        reporting.replot(args.replot, args.docs, name, lambda data, path: plot(data, path, small=True))
    return True


def save(args, name, data, plot):
    """<out>/<name>.json and .png, and with --docs the small copy of the chart."""
    os.makedirs(args.out, exist_ok=True)
    reporting.save_outputs(args.out, name, data, lambda path: plot(data, path))
    if args.docs:
        os.makedirs(args.docs, exist_ok=True)
        plot(data, os.path.join(args.docs, f"{name}.png"), small=True)

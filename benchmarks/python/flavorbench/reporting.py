"""What the scripts write: the command line every one of them has (--quick, --out), JSON, tables on stdout and
matplotlib charts."""
import argparse
import io
import json
import math
import os
import re

import numpy as np

from ._config import SOURCE_DIR


SMOKE_RUN_TEXT = "smoke run (--quick): not a measurement"
# Whether the charts being drawn come from a --quick run (set by parse_args of parser(), replot() and
# set_smoke_run()): save_figure() then watermarks them with SMOKE_RUN_TEXT.
_smoke_run = False


def set_smoke_run(quick):
    """Mark the charts saved from now on as those of a --quick run (True) or of a measurement (False)."""
    global _smoke_run
    _smoke_run = bool(quick)


class _Parser(argparse.ArgumentParser):
    def parse_args(self, *args, **kwargs):
        result = super().parse_args(*args, **kwargs)
        set_smoke_run(getattr(result, "quick", False))
        return result


def parser(doc, name, quick_help="smoke run of a few seconds (short T, coarser reference)",
           out_help="output directory"):
    """An ArgumentParser with --quick and --out (default results/<name> in the source tree); its parse_args() marks
    the charts of a --quick run as smoke runs (set_smoke_run)."""
    p = _Parser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help=quick_help)
    p.add_argument("--out", default=os.path.join(SOURCE_DIR, "results", name), help=out_help)
    return p


def jsonable(obj):
    """obj with NumPy values as plain ones, and inf and nan as None (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return None if not math.isfinite(float(obj)) else float(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def write_json(path, data, strict=True):
    """data as JSON at path; strict: through jsonable(), otherwise as it is (inf and NaN stay)."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(jsonable(data) if strict else data, f, indent=1, default=float)


def save_outputs(out, name, data, plot):
    """<out>/<name>.json (not strict: NaN stays NaN) and <out>/<name>.png drawn by plot(path)."""
    json_path, png_path = os.path.join(out, f"{name}.json"), os.path.join(out, f"{name}.png")
    write_json(json_path, data, strict=False)
    plot(png_path)
    print(f"\nwrote {json_path} and {png_path}")


def replot(json_path, out, name, plot):
    """Redraw <out>/<name>.png with plot(data, path) from the JSON of an earlier run (the scenes' --replot)."""
    with open(json_path, encoding="utf-8") as f:
        data = json.load(f)
    set_smoke_run(data.get("quick", False) if isinstance(data, dict) else False)
    os.makedirs(out, exist_ok=True)
    plot(data, os.path.join(out, f"{name}.png"))


def greek(label):
    """A run's label in the charts' notation: "d=0.1 t=0.01" (FLAVOR's mesostep and microstep) as "δ = 0.1, τ = 0.01",
    "H=", "h=" as "H = ", "h = " (the JSON and the tables keep the labels as they are)."""
    label = re.sub(r"\s*\bt=", ", τ = ", re.sub(r"\bd=", "δ = ", label))
    label = re.sub(r"\b([hH])=", r"\1 = ", label)
    label = re.sub(r"(\d) pi\b", r"\1π", label.replace("tau=delta", "τ = δ"))
    return label.replace("stiff x tau/delta", "stiff × τ/δ").replace("omega", "ω").replace("gamma", "γ")


def pyplot():
    """matplotlib.pyplot on the Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def mark_smoke_run(fig):
    """Watermark a figure across its middle with SMOKE_RUN_TEXT."""
    fig.text(0.5, 0.5, SMOKE_RUN_TEXT, ha="center", va="center", rotation=18, fontsize=30, color="tab:red",
             alpha=0.3, zorder=1000)


def note_failed(ax, failed, where=(0.99, 0.98)):
    """List the runs that failed (blew up: no finite value) in a box in the corner of ax, inside the axes and in
    front of them, so that they are shown but set no scale.  failed: names."""
    if failed:
        ax.text(*where, "failed (not drawn):\n" + "\n".join(failed), transform=ax.transAxes, ha="right", va="top",
                fontsize=8, color="tab:red", zorder=10,
                bbox=dict(boxstyle="round", facecolor="white", edgecolor="tab:red", alpha=0.9))


def save_figure(fig, path, dpi, small=False):
    """Save and close a figure; small=True quantizes it to a 64-colour palette (docs/ copies must stay small).  The
    charts of a --quick run (set_smoke_run) are watermarked as smoke runs."""
    if _smoke_run:
        mark_smoke_run(fig)
    if small:
        from PIL import Image
        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=dpi, format="png")
        buffer.seek(0)
        Image.open(buffer).convert("RGB").quantize(colors=64, method=Image.Quantize.MEDIANCUT).save(path,
                                                                                                    optimize=True)
    else:
        fig.savefig(path, dpi=dpi)
    pyplot().close(fig)


def table(title, columns, rows):
    """columns: [(header, width, format)], rows: lists of values (str values are left as they are)."""
    print(f"\n{title}")
    head = " ".join(f"{h:>{w}s}" if i else f"{h:{w}s}" for i, (h, w, _) in enumerate(columns))
    print(head)
    print("-" * len(head))
    for row in rows:
        cells = []
        for i, ((_, w, fmt), v) in enumerate(zip(columns, row)):
            text = v if isinstance(v, str) else format(v, fmt)
            cells.append(f"{text:>{w}s}" if i else f"{text:{w}s}")
        print(" ".join(cells))

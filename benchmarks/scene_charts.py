#!/usr/bin/env python3
"""The molecular scenes' verdict charts in docs/, redrawn from the stored results their claims rest on; runs nothing.

- docs/drude_water.png: SWM4-NDP water, five paired seeds (examples/drude_water/results/density/seed_summary.json:
  each observable's t against DrudeLangevinIntegrator at 0.125 fs) and the interleaved timing
  (examples/drude_water/results/density/interleaved_timing.json: ns/day per round, 1 and 2 threads).
- docs/villin.png: villin in water, speed against LangevinMiddleIntegrator at 4 fs with hydrogen mass repartitioning
  (examples/villin/results/hmr_peers.json and hmr_peers_run2.json, interleaved rounds) and accuracy against
  LangevinMiddle at 2 fs: the recipe's and MTSLangevin's seven paired runs (mean ± standard error over the runs, the
  table of examples/villin/README.md, "The angles of the planar centres soft"), each HMR peer's runs from the JSONs.

    PYTHONPATH=build/python .venv/bin/python benchmarks/scene_charts.py [--out docs]
"""
import argparse
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DRUDE = os.path.join(ROOT, "examples", "drude_water", "results", "density")
VILLIN = os.path.join(ROOT, "examples", "villin", "results")
plt.rcParams.update({"font.size": 11, "axes.titlesize": 12, "axes.labelsize": 11, "legend.fontsize": 10})


def load(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def clipped(ax, t, y, limit, colour, marker, label=None):
    """A point at t (clipped to ±limit, with its value written beside it)."""
    if abs(t) <= limit:
        ax.plot(t, y, marker, color=colour, ms=8, label=label)
    else:
        x = np.sign(t) * limit
        ax.plot(x, y, ">" if t > 0 else "<", color=colour, ms=9, label=label)
        ax.annotate("%+.0fσ" % t, (x, y), xytext=(-6 if t > 0 else 6, 7), textcoords="offset points",
                    ha="right" if t > 0 else "left", fontsize=10, color=colour)


def observable_legend(ax, titles, colours, markers):
    """The observables' legend below the axes, where it hides no point."""
    handles = [plt.Line2D([], [], ls="", marker=m, color=c, ms=8) for c, m in zip(colours, markers)]
    handles.append(plt.Rectangle((0, 0), 1, 1, color="0.88"))
    ax.legend(handles, list(titles) + ["within ±2"], loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=3,
              frameon=False)


def drude_water(out):
    summary = load(os.path.join(DRUDE, "seed_summary.json"))
    timing = load(os.path.join(DRUDE, "interleaved_timing.json"))
    observables = [("induced_ratio", "induced dipoles / SCF"), ("dipole", "molecular dipole"),
                   ("pe_per_molecule", "potential energy"), ("g_oo_peak", "g_OO first peak"),
                   ("t_com", "molecules' temperature"), ("t_drude", "Drude temperature")]
    peers = [("DrudeLangevin_1fs", "DrudeLangevin H = 1 fs\n(the peer)", "black"),
             ("WarpedMiddle_2.5fs", "SIM Warped Middle\nH = 2.5 fs (the recipe)", "tab:green"),
             ("WarpedMiddleLimitedScaled_3fs", "SIM, phase limit 2.05\nand friction scaling, H = 3 fs", "tab:olive"),
             ("WarpedMiddleLimitedScaled_3.5fs", "the same, H = 3.5 fs", "tab:red")]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(15, 7.5), gridspec_kw={"width_ratios": [1.6, 1]})
    limit = 8
    markers = ["o", "s", "D", "^", "v", "P"]
    colours = plt.cm.tab10(np.arange(len(observables)))
    for row, (key, label, _) in enumerate(peers):
        run = summary["runs"][key]
        for j, (name, title) in enumerate(observables):
            y = row + (j - 2.5) * 0.1
            clipped(ax, run[name + "_t"], y, limit, colours[j], markers[j])
    ax.axvspan(-2, 2, color="0.88", zorder=0)
    ax.axvline(0, color="0.5", lw=0.8)
    ax.set_yticks(range(len(peers)), [p[1] + ("" if summary["runs"][p[0]]["integrator"] == "DrudeLangevin" or
                                              p[0] == "WarpedMiddle_2.5fs" else
                                              "\n(%.2f× in the seed runs)"
                                              % summary["runs"][p[0]]["ns_per_day_over_DrudeLangevin_1fs"])
                                       for p in peers])
    ax.set_ylim(len(peers) - 0.5, -0.5)
    ax.set_xlim(-limit - 0.5, limit + 0.5)
    ax.set_xlabel("t: difference from DrudeLangevin H = 0.125 fs over 5 paired seeds\n(in standard errors; arrows: "
                  "off the axis, value written)")
    ax.set_title("accuracy")
    observable_legend(ax, [t for _, t in observables], colours, markers)

    speed_peers = [("DrudeLangevinWall 1.5 fs", "DrudeLangevin 1.5 fs + 0.02-nm wall", "0.4"),
                   ("WarpedMiddle 2.5 fs", "SIM Warped Middle H = 2.5 fs", "tab:green")]
    for row, (key, label, colour) in enumerate(speed_peers):
        for offset, threads in ((-0.12, "2"), (0.12, "1")):
            rounds = timing["threads"][threads]["ns_per_day"]
            ratio = np.array(rounds[key]) / np.array(rounds["DrudeLangevin 1 fs"])
            median = np.median(ratio)
            bx.plot(ratio, np.full(len(ratio), row + offset), "|", color=colour, ms=10, alpha=0.6)
            bx.plot(median, row + offset, "o" if threads == "2" else "s", color=colour, ms=9)
            bx.annotate("%.2f× (%s thread%s)" % (median, threads, "s" if threads == "2" else ""),
                        (median, row + offset), xytext=(0, 8), textcoords="offset points", ha="center", fontsize=10)
    bx.axvline(1, color="black", lw=1)
    bx.set_yticks(range(len(speed_peers)), [p[1] for p in speed_peers])
    bx.set_ylim(len(speed_peers) - 0.4, -0.6)
    bx.set_xlim(0.8, 3.0)
    bx.set_xlabel("ns/day ÷ DrudeLangevin H = 1 fs's\n(8 interleaved rounds: ticks; median: dot)")
    bx.set_title("speed (CPU platform)")
    recipe = summary["runs"]["WarpedMiddle_2.5fs"]
    reference = summary["runs"]["DrudeLangevin_0.125fs"]
    fig.suptitle("SWM4-NDP water (256 molecules, PME): StochasticImpulseIntegrator wins. At H = 2.5 fs it runs %.2f× "
                 "DrudeLangevinIntegrator at 1 fs (2 threads),\nevery observable within %.1f standard errors of "
                 "DrudeLangevin at 0.125 fs over 5 seeds (the molecules %.1f %% cool); DrudeLangevin 1 fs's Drudes "
                 "are %.0f %% hot"
                 % (np.median(np.array(timing["threads"]["2"]["ns_per_day"]["WarpedMiddle 2.5 fs"])
                              / np.array(timing["threads"]["2"]["ns_per_day"]["DrudeLangevin 1 fs"])),
                    max(abs(recipe[name + "_t"]) for name, _ in observables),
                    100 * (1 - recipe["t_com"][0] / reference["t_com"][0]),
                    100 * (summary["runs"]["DrudeLangevin_1fs"]["t_drude"][0] / reference["t_drude"][0] - 1)),
                 fontsize=13)
    fig.subplots_adjust(left=0.16, right=0.98, top=0.86, bottom=0.3, wspace=0.6)
    path = os.path.join(out, "drude_water.png")
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


# examples/villin/README.md, "The angles of the planar centres soft, and the Middle placement": paired differences
# against LangevinMiddle 2 fs of the same run, mean ± standard error over 7 runs (T and T protein in K, the others
# in %).
SEVEN_RUNS = {
    "FLAVOR δ = 2.5 fs, τ = 1 fs\n(the recipe; 7 runs)": {"T": (0.6, 0.5), "T_protein": (1.4, 1.3),
                                                          "bond_rms all": (-0.4, 0.3), "angle_rms with H": (-0.1, 0.3),
                                                          "angle_rms heavy atoms": (0.2, 0.3),
                                                          "backbone_rmsd": (-8, 5)},
    "MTSLangevin 4 fs / 4\n(7 runs)": {"T": (-2.2, 0.6), "T_protein": (-4.6, 1.7), "bond_rms all": (-0.1, 0.6),
                                       "angle_rms with H": (0.4, 0.4), "angle_rms heavy atoms": (-0.4, 0.3),
                                       "backbone_rmsd": (-5, 6)},
}
VILLIN_OBSERVABLES = [("T", "temperature"), ("T_protein", "protein temperature"), ("bond_rms all", "bond spread"),
                      ("angle_rms with H", "angles with H"), ("angle_rms heavy atoms", "heavy-atom angles"),
                      ("backbone_rmsd", "backbone RMSD")]
BASELINE = "LangevinMiddle 4 fs HMR 1.5 amu"
HMR_PEERS = [(BASELINE, "LangevinMiddle 4 fs, HMR 1.5 amu\n(OpenMM's own; 2 runs)"),
             ("FLAVOR ArtificialProjected bonds+nonplanar angles Middle HMR 1.5 amu δ=5 fs τ=1 fs",
              "FLAVOR HMR 1.5 amu δ = 5 fs\n(1 run)"),
             ("FLAVOR ArtificialProjected bonds+nonplanar angles Middle HMR 3 amu δ=8 fs τ=1 fs",
              "FLAVOR HMR 3 amu δ = 8 fs\n(2 runs)")]


def villin(out):
    runs = [load(os.path.join(VILLIN, name)) for name in ("hmr_peers.json", "hmr_peers_run2.json")]
    fig, (bx, ax) = plt.subplots(1, 2, figsize=(16, 8), gridspec_kw={"width_ratios": [1, 1.4]})
    # Speed: each run's median ratio to LangevinMiddle 4 fs HMR 1.5 amu over its interleaved rounds.
    rows = [("LangevinMiddle 2 fs", "LangevinMiddle 2 fs\n(the accuracy reference)", "0.4")] + \
        [(key, label, colour) for (key, label), colour in zip(HMR_PEERS, ["black", "tab:blue", "tab:red"])]
    recipe_row = len(rows)
    def speed_point(ratio, row, r, marker, colour):
        bx.plot(ratio, row, marker, color=colour, ms=9)
        if key != BASELINE or r == 0:  # one label per point, the first run's above, the second's below
            bx.annotate("%.2f×" % ratio, (ratio, row), xytext=(0, 9 if r == 0 else -17), textcoords="offset points",
                        ha="center", fontsize=10)

    for row, (key, label, colour) in enumerate(rows):
        for r, run in enumerate(runs):
            peer = next((p for p in run["peers"] if p["name"] == key), None)
            if peer is not None:
                speed_point(peer["interleaved_ratio"], row, r, "o", colour)
    # The recipe (no HMR) ran 1.14x LangevinMiddle 2 fs (the seven runs, interleaved): that times each run's
    # LangevinMiddle 2 fs ratio.
    key = None
    for r, run in enumerate(runs):
        lm2 = next(p for p in run["peers"] if p["name"] == "LangevinMiddle 2 fs")["interleaved_ratio"]
        speed_point(1.14 * lm2, recipe_row, r, "D", "tab:green")
    labels = [r[1] for r in rows] + ["FLAVOR δ = 2.5 fs, τ = 1 fs\n(the recipe, no HMR:\n1.14× LangevinMiddle 2 fs)"]
    bx.axvline(1, color="black", lw=1)
    bx.set_yticks(range(len(labels)), labels)
    bx.set_ylim(len(labels) - 0.5, -0.6)
    bx.set_xlim(0, 2.5)
    bx.set_xlabel("ns/day ÷ LangevinMiddle 4 fs HMR 1.5 amu's\n(median over interleaved rounds, 2 threads, CPU)")
    bx.set_title("speed (a dot per run)")

    labels = list(SEVEN_RUNS) + [label for _, label in HMR_PEERS]
    colours = plt.cm.tab10(np.arange(len(VILLIN_OBSERVABLES)))
    markers = ["o", "s", "D", "^", "v", "P"]
    limit = 8
    for row, label in enumerate(SEVEN_RUNS):
        for j, (key, title) in enumerate(VILLIN_OBSERVABLES):
            mean, error = SEVEN_RUNS[label][key]
            clipped(ax, mean / error, row + (j - 2.5) * 0.1, limit, colours[j], markers[j])
    for i, (key, _) in enumerate(HMR_PEERS):
        row = len(SEVEN_RUNS) + i
        for r, run in enumerate(runs):
            peer = next((p for p in run["peers"] if p["name"] == key), None)
            reference = next(p for p in run["peers"] if p["name"] == "LangevinMiddle 2 fs")
            if peer is None:
                continue
            for j, (name, _) in enumerate(VILLIN_OBSERVABLES):
                sigma = (peer[name] - reference[name]) / np.hypot(peer[name + "_error"], reference[name + "_error"])
                clipped(ax, sigma, row + (j - 2.5) * 0.1 + r * 0.04, limit, colours[j], markers[j])
    ax.axvspan(-2, 2, color="0.88", zorder=0)
    ax.axvline(0, color="0.5", lw=0.8)
    ax.set_yticks(range(len(labels)), labels)
    ax.set_ylim(len(labels) - 0.5, -0.5)
    ax.set_xlim(-limit - 0.5, limit + 0.5)
    ax.set_xlabel("difference from LangevinMiddle 2 fs in standard errors\n(over the 7 runs for the first two rows; "
                  "of each run's 5 block means\nfor the others; arrows: off the axis, value written)")
    ax.set_title("accuracy (a marker per observable and run)")
    observable_legend(ax, [t for _, t in VILLIN_OBSERVABLES], colours, markers)
    fig.suptitle("Villin in water (8,867 atoms, PME): FlavorIntegrator does not win. LangevinMiddleIntegrator at 4 fs "
                 "with HMR 1.5 amu is the\nbetter choice: our accurate recipe (δ = 2.5 fs) runs about 0.5× it; we run "
                 "faster only at δ = 8 fs with HMR 3 amu, where the angles are wide", fontsize=13)
    fig.subplots_adjust(left=0.2, right=0.98, top=0.86, bottom=0.3, wspace=0.55)
    path = os.path.join(out, "villin.png")
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=os.path.join(ROOT, "docs"), help="folder of the PNGs (default docs)")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for path in (drude_water(args.out), villin(args.out)):
        print("wrote", path)


if __name__ == "__main__":
    main()

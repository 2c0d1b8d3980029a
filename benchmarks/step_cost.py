#!/usr/bin/env python3
"""Per-step cost of FlavorIntegrator against the force evaluations it needs and against its peers.

(a) One FPU chain (FLAVORS paper eq. 6.7, 6 particles) on the Reference platform: the native FlavorIntegrator
    (Verlet and SymplecticEuler schemes), the same Verlet FLAVOR written as an openmm.CustomIntegrator,
    openmm.VerletIntegrator, and the cost of one force-group evaluation.
(b) ~1700 independent FPU chains (10^4 particles, spread along y) on the CPU platform with Threads = 1 and 2.
(c) openmm.mtsintegrator.MTSIntegrator and LangevinMiddleIntegrator on both, for context.

A force group's evaluation cost is estimated, as OpenMM offers no public call for it, by the per-step time of a
VerletIntegrator restricted to that group (setIntegrationForceGroups), which includes Verlet's own update loop and
so overestimates it.  The optional C++ helper (benchmarks/step_cost.cpp, target `step_cost`) also measures it
exactly: an Integrator whose step is one ContextImpl::calcForcesAndEnergy() call.

Every time is integrator.step(N) with N sized so a batch takes --seconds, repeated --repeats times round-robin
over all integrators of a part (background load then hits them alike); the minimum is reported.  Because wall
times on a shared machine are noisy, the helper is also run under valgrind's callgrind (if both are found; skip with
--no-instructions): instructions per step, from the difference of two runs with different step counts, give
load-independent cost ratios.  This is a benchmark: it prints what it measures and asserts nothing.

    PYTHONPATH=build/python .venv/bin/python benchmarks/step_cost.py [--quick] [--out DIR] [--helper PATH]
"""
import os
import shutil
import sys
import time

import numpy as np
import openmm as mm
import openmm.unit as unit

from flavorbench import reporting
from flavorbench.helper import count_instructions, find_helper, run_helper
from flavorbench.runners import flavor, mts, start_context, time_batches, verlet
from flavorbench.systems import SOFT_GROUP as SOFT, STIFF_GROUP as STIFF, chain_positions, fpu_system

M, OMEGA = 3, 200.0
DELTA, TAU, H = 2e-3, 1e-4, 1e-4


def custom_flavor_verlet():
    """The Verlet FLAVOR (docs/ARCHITECTURE.md) as a CustomIntegrator: "f" is every group, "f0" the soft group."""
    integrator = mm.CustomIntegrator(DELTA)
    integrator.addGlobalVariable("tau", TAU)
    integrator.addGlobalVariable("rest", DELTA - TAU)
    integrator.addComputePerDof("v", "v + 0.5*tau*f/m")
    integrator.addComputePerDof("x", "x + 0.5*tau*v")
    integrator.addComputePerDof("v", "v + 0.5*rest*f0/m")
    integrator.addComputePerDof("x", "x + rest*v")
    integrator.addComputePerDof("v", "v + 0.5*rest*f0/m")
    integrator.addComputePerDof("x", "x + 0.5*tau*v")
    integrator.addComputePerDof("v", "v + 0.5*tau*f/m")
    return integrator


INTEGRATORS = {
    # key: (label, factory, step size)
    "flavor_verlet": ("FlavorIntegrator Verlet (native)", lambda: flavor(DELTA, TAU, "Verlet"), DELTA),
    "flavor_euler": ("FlavorIntegrator SymplecticEuler (native)", lambda: flavor(DELTA, TAU, "SymplecticEuler"), DELTA),
    "custom_flavor_verlet": ("Verlet FLAVOR as CustomIntegrator", custom_flavor_verlet, DELTA),
    "verlet": ("VerletIntegrator (all groups)", lambda: verlet(H), H),
    "verlet_soft": ("VerletIntegrator groups {0} (soft)", lambda: verlet(H, {SOFT}), H),
    "verlet_stiff": ("VerletIntegrator groups {1} (stiff)", lambda: verlet(H, {STIFF}), H),
    "mts": ("MTSIntegrator [(0,1),(1,20)]", lambda: mts(DELTA, 20), DELTA),
    "langevin_middle": ("LangevinMiddleIntegrator", lambda: mm.LangevinMiddleIntegrator(300, 1.0, H), H),
}


def make_context(system, positions, key, platform, properties):
    integrator = INTEGRATORS[key][1]()
    return start_context(system, integrator, 0.0, positions, platform=platform, properties=properties), integrator


def python_loop_cost(integrator, n):
    """us per step(1) call from a Python loop: what a per-step Python loop would (wrongly) measure."""
    start = time.perf_counter()
    for _ in range(n):
        integrator.step(1)
    return 1e6 * (time.perf_counter() - start) / n


def instruction_counts(helper, valgrind, args, names, steps, label):
    counts = {}
    for name in names:
        counts[name] = count_instructions(helper, valgrind, args, name, steps)
        print(f"  [{label}] callgrind {name}: {counts[name]:.4g} instructions/step", file=sys.stderr, flush=True)
    f = {k: v for k, v in counts.items()}
    out = {"instructions_per_step": counts,
           "force_cost": force_costs(f["force_soft"], f["force_stiff"], f["force_all"])}
    for scheme in ("flavor_verlet", "flavor_euler"):
        if scheme in counts:
            out[f"{scheme}_over_force_cost"] = {count: counts[scheme] / cost
                                                for count, cost in out["force_cost"][scheme].items()}
    if "verlet" in counts:
        out["verlet_over_force_all"] = counts["verlet"] / counts["force_all"]
    return out


def custom_matches_native(system, positions):
    """Max |x_native - x_custom| after 200 steps from the same state: the two must be the same scheme."""
    results = []
    for key in ("flavor_verlet", "custom_flavor_verlet"):
        context, integrator = make_context(system, positions, key, "Reference", {})
        integrator.step(200)
        results.append(context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer))
    return float(np.max(np.abs(results[0] - results[1])))


def force_costs(c_soft, c_stiff, c_all):
    """Force-evaluation cost per step of each scheme: as the brief counts it (all = soft + stiff) and as the schedule
    evaluates it (one all-groups evaluation serves the K_all kicks; the last kick of a step is cached for the next)."""
    return {
        "flavor_verlet": {"soft+stiff count (3 soft + 1 stiff)": 3 * c_soft + c_stiff,
                          "as scheduled (2 soft + 1 all)": 2 * c_soft + c_all},
        "flavor_euler": {"soft+stiff count (2 soft + 1 stiff)": 2 * c_soft + c_stiff,
                         "as scheduled (1 soft + 1 all)": c_soft + c_all},
    }


def main():
    parser = reporting.parser(__doc__, "bench",
                              quick_help="smoke run: 170 chains, short batches, 2 repeats, no instruction counts")
    parser.add_argument("--chains", type=int, default=1700, help="FPU chains on the CPU platform (6 particles each)")
    parser.add_argument("--seconds", type=float, default=0.15, help="target duration of one timed batch")
    parser.add_argument("--repeats", type=int, default=7, help="timed batches per integrator (minimum reported)")
    parser.add_argument("--helper", default=None, help="path of the C++ step_cost helper (default: search)")
    parser.add_argument("--no-helper", action="store_true", help="do not run the C++ helper")
    parser.add_argument("--no-instructions", action="store_true", help="skip the callgrind instruction counts")
    args = parser.parse_args()
    if args.quick:
        args.chains, args.seconds, args.repeats = min(args.chains, 170), 0.03, 2
        args.no_instructions = True
    helper = None if args.no_helper else find_helper(args.helper)
    valgrind = None if (args.no_instructions or helper is None) else shutil.which("valgrind")
    started = time.perf_counter()
    data = {"openmm_version": mm.__version__, "delta": DELTA, "tau": TAU, "h": H, "omega": OMEGA,
            "seconds_per_batch": args.seconds, "repeats": args.repeats, "helper": helper,
            "cpu_count": os.cpu_count(), "load_average_at_start": os.getloadavg()}

    # (a) One chain on Reference.
    print("(a) Reference, one FPU chain", file=sys.stderr)
    small = fpu_system(M, OMEGA)
    q_small = chain_positions(M, OMEGA, 1)
    keys_a = ["flavor_verlet", "flavor_euler", "custom_flavor_verlet", "verlet", "verlet_soft", "verlet_stiff", "mts",
              "langevin_middle"]
    cases = {k: make_context(small, q_small, k, "Reference", {}) for k in keys_a}
    ref = time_batches(cases, args.seconds, args.repeats, "Reference")
    loop_n = max(1000, int(ref["flavor_verlet"]["steps_per_batch"] / 10))
    ref_loop = python_loop_cost(cases["flavor_verlet"][1], loop_n)
    del cases
    ref_cpp = run_helper(helper, ["--platform", "Reference", "--seconds", str(args.seconds), "--repeats",
                                  str(args.repeats), "force_soft", "force_stiff", "force_all", "flavor_verlet",
                                  "flavor_euler", "verlet"], "Reference")
    part_a = {"platform": "Reference", "particles": small.getNumParticles(), "integrators": ref,
              "python_step1_loop_us_per_step_flavor_verlet": ref_loop,
              "custom_vs_native_max_position_difference_after_200_steps": custom_matches_native(small, q_small),
              "cpp": ref_cpp}
    part_a["ratios"] = ratios(ref, ref_cpp, custom=True)
    if valgrind:
        part_a["callgrind"] = instruction_counts(
            helper, valgrind, ["--platform", "Reference"],
            ["flavor_verlet", "flavor_euler", "force_soft", "force_stiff", "force_all", "verlet"], (200, 600),
            "Reference")
    data["a_reference"] = part_a

    # (b) and (c): many chains on CPU.
    big = fpu_system(M, OMEGA, args.chains)
    q_big = chain_positions(M, OMEGA, args.chains)
    print(f"(b) CPU, {args.chains} FPU chains ({big.getNumParticles()} particles)", file=sys.stderr)
    keys_b = ["flavor_verlet", "flavor_euler", "verlet", "verlet_soft", "verlet_stiff"]
    cases = {}
    for threads in (1, 2):
        for k in keys_b:
            cases[f"{k}@{threads}"] = make_context(big, q_big, k, "CPU", {"Threads": str(threads)})
    for k in ("mts", "langevin_middle"):
        cases[f"{k}@2"] = make_context(big, q_big, k, "CPU", {"Threads": "2"})
    cpu = time_batches(cases, args.seconds, args.repeats, "CPU")
    del cases
    part_b = {"platform": "CPU", "chains": args.chains, "particles": big.getNumParticles(), "threads": {}}
    for threads in (1, 2):
        timings = {k: cpu[f"{k}@{threads}"] for k in keys_b}
        if threads == 2:
            timings.update({k: cpu[f"{k}@2"] for k in ("mts", "langevin_middle")})
        cpp = run_helper(helper, ["--platform", "CPU", "--chains", str(args.chains), "--threads", str(threads),
                                  "--seconds", str(args.seconds), "--repeats", str(args.repeats), "force_soft",
                                  "force_stiff", "force_all", "flavor_verlet"], f"CPU Threads={threads}")
        part_b["threads"][str(threads)] = {"integrators": timings, "cpp": cpp, "ratios": ratios(timings, cpp)}
    t1, t2 = part_b["threads"]["1"]["integrators"], part_b["threads"]["2"]["integrators"]
    part_b["thread_speedup"] = {k: t1[k]["us_per_step"] / t2[k]["us_per_step"] for k in keys_b}
    c1, c2 = part_b["threads"]["1"]["cpp"], part_b["threads"]["2"]["cpp"]
    if c1 and c2:
        part_b["thread_speedup_cpp"] = {k: c1[k]["us_per_step_min"] / c2[k]["us_per_step_min"] for k in c1}
    if valgrind:
        part_b["callgrind_threads_1"] = instruction_counts(
            helper, valgrind, ["--platform", "CPU", "--threads", "1", "--chains", str(args.chains)],
            ["flavor_verlet", "force_soft", "force_stiff", "force_all", "verlet"], (5, 15), "CPU Threads=1")
    data["b_cpu"] = part_b
    data["wall_s"] = time.perf_counter() - started

    report(data)
    json_path = os.path.join(args.out, "step_cost.json")
    reporting.write_json(json_path, data, strict=False)
    png_path = os.path.join(args.out, "step_cost.png")
    plot(data, png_path)
    print(f"\nwrote {json_path} and {png_path} ({data['wall_s']:.0f} s)")


def ratios(timings, cpp, custom=False):
    """The headline ratios; force costs from Verlet-with-groups and, if present, from the C++ force-only timings."""
    t = {k: v["us_per_step"] for k, v in timings.items()}
    out = {"force_cost_verlet_groups": force_costs(t["verlet_soft"], t["verlet_stiff"], t["verlet"])}
    if cpp:
        f = {k: v["us_per_step_min"] for k, v in cpp.items()}
        out["force_cost_cpp"] = force_costs(f["force_soft"], f["force_stiff"], f["force_all"])
    for scheme in ("flavor_verlet", "flavor_euler"):
        if scheme not in t:
            continue
        for source in ("force_cost_verlet_groups", "force_cost_cpp"):
            if source in out:
                for count, cost in out[source][scheme].items():
                    out.setdefault(f"{scheme}_over_force_cost", {})[f"{source}: {count}"] = t[scheme] / cost
        if cpp and scheme in cpp:
            out.setdefault(f"{scheme}_cpp_over_force_cost_cpp", {}).update(
                {count: cpp[scheme]["us_per_step_min"] / cost for count, cost in out["force_cost_cpp"][scheme].items()})
    if custom:
        out["custom_over_native_flavor_verlet"] = t["custom_flavor_verlet"] / t["flavor_verlet"]
    return out


def report(data):
    a = data["a_reference"]
    print(f"OpenMM {data['openmm_version']}; FLAVOR delta = {DELTA:g}, tau = {TAU:g}; Verlet/Langevin h = {H:g}; "
          f"{data['cpu_count']} cores, load average at start {data['load_average_at_start'][0]:.2f}")
    print(f"times: minimum over {data['repeats']} round-robin batches of integrator.step(N), "
          f"~{data['seconds_per_batch']:g} s each\n")
    print(f"(a) Reference platform, one FPU chain ({a['particles']} particles)")
    table(a["integrators"], a["cpp"])
    print(f"    Python loop of step(1), native Verlet FLAVOR: {a['python_step1_loop_us_per_step_flavor_verlet']:.3f} "
          f"us/step (why step(N) is timed instead)")
    print(f"    CustomIntegrator vs native after 200 steps: max |dx| = "
          f"{a['custom_vs_native_max_position_difference_after_200_steps']:.2e} nm (same scheme)")
    r = a["ratios"]
    print(f"    native Verlet FLAVOR is {r['custom_over_native_flavor_verlet']:.1f}x faster than the CustomIntegrator "
          f"(target >= 10x)")
    print_force_ratios(r, "1.3")
    print_instruction_ratios(a.get("callgrind"), "1.3")
    b = data["b_cpu"]
    print(f"\n(b) CPU platform, {b['chains']} FPU chains ({b['particles']} particles)")
    for threads, part in b["threads"].items():
        print(f"  Threads = {threads}")
        table(part["integrators"], part["cpp"])
        print_force_ratios(part["ratios"], "1.2")
    print("  thread speedup (Threads=1 time / Threads=2 time; target for FLAVOR: > 1): " +
          ", ".join(f"{k} {v:.2f}x" for k, v in b["thread_speedup"].items()))
    if "thread_speedup_cpp" in b:
        print("  thread speedup, C++ timings: " +
              ", ".join(f"{k} {v:.2f}x" for k, v in b["thread_speedup_cpp"].items()))
    if b.get("callgrind_threads_1"):
        print("  Threads = 1, instruction counts:")
        print_instruction_ratios(b["callgrind_threads_1"], "1.2")


def print_instruction_ratios(c, target):
    if not c:
        return
    print("    callgrind instructions per step (all threads; load-independent): " +
          ", ".join(f"{k} {v:.4g}" for k, v in c["instructions_per_step"].items()))
    for scheme, name in (("flavor_verlet", "Verlet"), ("flavor_euler", "SymplecticEuler")):
        for count, value in c.get(f"{scheme}_over_force_cost", {}).items():
            print(f"      {value:6.2f}x   instructions: native {name} FLAVOR / force evaluations, {count} "
                  f"(target <= {target}x)")
    if "verlet_over_force_all" in c:
        print(f"      {c['verlet_over_force_all']:6.2f}x   instructions: VerletIntegrator / one all-groups evaluation "
              f"(OpenMM's own overhead, for comparison)")


def table(timings, cpp):
    print(f"    {'integrator':44s} {'us/step':>10s} {'median':>10s} {'step':>8s} {'us per ps':>11s}")
    for key, v in timings.items():
        label, _, step = INTEGRATORS[key]
        print(f"    {label:44s} {v['us_per_step']:10.4g} {v['us_per_step_median']:10.4g} {step:8g} "
              f"{v['us_per_step'] / step:11.4g}")
    if cpp:
        names = {"force_soft": "C++: one soft-group (0) evaluation",
                 "force_stiff": "C++: one stiff-group (1) evaluation",
                 "force_all": "C++: one all-groups evaluation", "flavor_verlet": "C++: FlavorIntegrator Verlet",
                 "flavor_euler": "C++: FlavorIntegrator SymplecticEuler", "verlet": "C++: VerletIntegrator"}
        for key, v in cpp.items():
            print(f"    {names.get(key, key):44s} {v['us_per_step_min']:10.4g} {v['us_per_step_median']:10.4g}")


def print_force_ratios(r, target):
    """Three of the ratios in the JSON: the Verlet-with-groups estimate counted both ways, and the exact C++ one."""
    for scheme, name in (("flavor_verlet", "Verlet"), ("flavor_euler", "SymplecticEuler")):
        if f"{scheme}_over_force_cost" not in r:
            continue
        print(f"    native {name} FLAVOR / its force-evaluation cost (target <= {target}x):")
        for source, value in r[f"{scheme}_over_force_cost"].items():
            if source.startswith("force_cost_verlet_groups"):
                count = source.split(": ", 1)[1]
                print(f"      {value:6.2f}x   forces = VerletIntegrator with one group per step, {count}")
        for count, value in r.get(f"{scheme}_cpp_over_force_cost_cpp", {}).items():
            if count.startswith("as scheduled"):
                print(f"      {value:6.2f}x   C++: FLAVOR step vs calcForcesAndEnergy() calls, {count}")


def plot(data, path):
    plt = reporting.pyplot()
    counts = [(label, c) for label, c in (("Reference", data["a_reference"].get("callgrind")),
                                          ("CPU, Threads=1", data["b_cpu"].get("callgrind_threads_1"))) if c]
    fig = plt.figure(figsize=(16, 11 if counts else 6.5))
    grid = fig.add_gridspec(2 if counts else 1, 2, height_ratios=[1.3, 1] if counts else [1])
    axes = [fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])]
    if counts:
        axes.append(fig.add_subplot(grid[1, :]))
    a = data["a_reference"]
    labels, values, colors = [], [], []
    verdict = "against its force evaluations and other integrators"
    palette = {"flavor": "tab:red", "custom": "tab:orange", "verlet": "tab:blue", "force": "tab:gray",
               "other": "tab:green"}

    def kind(key):
        return ("custom" if key.startswith("custom") else "flavor" if key.startswith("flavor") else
                "verlet" if key.startswith("verlet") else "other")

    for key, v in a["integrators"].items():
        labels.append(INTEGRATORS[key][0])
        values.append(v["us_per_step"])
        colors.append(palette[kind(key)])
    for scheme in ("flavor_verlet", "flavor_euler"):
        for source in ("force_cost_verlet_groups", "force_cost_cpp"):
            costs = a["ratios"].get(source, {}).get(scheme)
            if costs:
                count, cost = list(costs.items())[0 if source == "force_cost_verlet_groups" else 1]
                name = {"flavor_verlet": "Verlet FLAVOR", "flavor_euler": "SymplecticEuler FLAVOR"}[scheme]
                labels.append(f"{name}: its force evaluations, {'Verlet groups' if 'verlet' in source else 'C++'}, "
                              f"{count}")
                values.append(cost)
                colors.append(palette["force"])
    ax = axes[0]
    ax.barh(range(len(values)), values, color=colors)
    ax.set_yticks(range(len(values)))
    ax.set_yticklabels(labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("wall time per step (µs, log scale)")
    ax.set_title(f"(a) Reference, one FPU chain ({a['particles']} particles)")
    for i, v in enumerate(values):
        ax.text(v, i, f" {v:.3g}", va="center", fontsize=7)

    b = data["b_cpu"]
    ax = axes[1]
    keys = list(b["threads"]["1"]["integrators"].keys())
    extra = [k for k in b["threads"]["2"]["integrators"] if k not in keys]
    rows = keys + extra + ["force cost (Verlet groups, 3 soft + 1 stiff)", "force cost (C++, 2 soft + 1 all)"]
    width = 0.4
    for j, threads in enumerate(("1", "2")):
        part = b["threads"][threads]
        vals = [part["integrators"][k]["us_per_step"] if k in part["integrators"] else np.nan for k in keys + extra]
        vals.append(list(part["ratios"]["force_cost_verlet_groups"]["flavor_verlet"].values())[0])
        cpp_cost = part["ratios"].get("force_cost_cpp", {}).get("flavor_verlet")
        vals.append(list(cpp_cost.values())[1] if cpp_cost else np.nan)
        pos = np.arange(len(rows)) + (j - 0.5) * width
        ax.barh(pos, vals, height=width, label=f"Threads = {threads}", color=["tab:blue", "tab:red"][j])
        for p, v in zip(pos, vals):
            if np.isfinite(v):
                ax.text(v, p, f" {v:.3g}", va="center", fontsize=7)
            else:
                # No bar: say so where it would be.
                ax.text(0.01, p, f"not measured with Threads = {threads}", va="center", fontsize=7, style="italic",
                        transform=ax.get_yaxis_transform())
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([INTEGRATORS[k][0] if k in INTEGRATORS else f"Verlet FLAVOR {k}" for k in rows], fontsize=7)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("wall time per step (µs, log scale)")
    ax.set_title(f"(b, c) CPU platform, {b['chains']} FPU chains ({b['particles']} particles)")
    ax.legend(fontsize=8, loc="lower right")
    if counts:
        ax = axes[2]
        labels, values, colors = [], [], []
        for platform, c in counts:
            for scheme, name in (("flavor_verlet", "Verlet FLAVOR"), ("flavor_euler", "SymplecticEuler FLAVOR")):
                for count, value in c.get(f"{scheme}_over_force_cost", {}).items():
                    labels.append(f"{platform}: {name} / forces, {count}")
                    values.append(value)
                    colors.append("tab:red")
            if "verlet_over_force_all" in c:
                labels.append(f"{platform}: VerletIntegrator / one all-groups evaluation")
                values.append(c["verlet_over_force_all"])
                colors.append("tab:blue")
        ax.barh(range(len(values)), values, color=colors)
        for i, v in enumerate(values):
            ax.text(v, i, f" {v:.2f}", va="center", fontsize=7)
        ax.axvline(1.3, color="k", ls="--", lw=0.8, label="targets 1.3 (Reference), 1.2 (CPU)")
        ax.axvline(1.2, color="k", ls=":", lw=0.8)
        ax.set_yticks(range(len(values)))
        ax.set_yticklabels(labels, fontsize=7)
        ax.invert_yaxis()
        ax.set_xlabel("instructions per step / instructions of its force evaluations (callgrind)")
        ax.set_title("step cost / cost of its force evaluations, in instructions per step\n(callgrind: independent "
                     "of machine load)", fontsize=10)
        flavor = [v for v, c in zip(values, colors) if c == "tab:red"]
        if flavor:
            verdict = (f"a FLAVOR step costs {min(flavor):.2f}–{max(flavor):.2f}× its force evaluations "
                       f"({'within' if max(flavor) <= 1.3 else 'above'} the 1.3 target)")
        ax.legend(fontsize=7)
    fig.suptitle(f"Per-step cost of FlavorIntegrator: {verdict}\nOpenMM {data['openmm_version']}, FPU chains "
                 f"(ω = {OMEGA:g} ps⁻¹); FLAVOR δ = {DELTA:g} ps, τ = {TAU:g} ps; Verlet and Langevin h = {H:g} ps; "
                 f"MTS outer step {DELTA:g} ps with 20 stiff substeps", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    reporting.save_figure(fig, path, 110)


if __name__ == "__main__":
    main()

"""Cost of one StochasticImpulseIntegrator step against one soft-group force evaluation plus its mode work, and how
the mode work grows with the size of the stiff components.

(a) The mode work (the exact stiff flow of every component, and its noise with friction) is measured as the step of
    the same integrator on the same chains with the soft forces removed; the soft evaluation as the step of a
    VerletIntegrator restricted to the soft group.  Reference platform, FPU chains (FLAVORS paper eq. 6.7).
(b) Mode work against sum_c n_c^2: PARTICLES particles in stiff linear chains of n_c particles each (HarmonicBondForce
    of length 0 between neighbours, no soft force), n_c from 2 to 256, friction 0 and 1/ps; the log-log slope of the
    step time against sum_c n_c^2 = PARTICLES n_c over the sizes that take the general path (n_c > 6: products with
    the eigenvectors, O(n_c^2) per component) and over n_c >= 32, where those products dominate.

    PYTHONPATH=build/python /usr/bin/python3 benchmarks/sim_step_cost.py [--chains N] [--quick] [--out DIR]
"""
import os
import sys
import time

import numpy as np
import openmm

import openmmflavors

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "common"))
import fpu_chain  # noqa: E402
import scene  # noqa: E402

OMEGA, M, H = 200.0, 3, 0.005
PARTICLES = 6144  # divisible by every component size of part (b)
COMPONENT_SIZES = [2, 3, 4, 6, 8, 16, 32, 64, 128, 256]
COMPILED_MAX = 6  # components of up to 6 particles run a flow compiled for their size


def per_step_us(system, integrator, positions, steps, repeats):
    """Best of `repeats` batches of `steps` steps, in microseconds per step."""
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions)
    integrator.step(5)
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        integrator.step(steps)
        best = min(best, (time.perf_counter() - start) / steps)
    return best * 1e6


def stiff_chains(particles, size):
    """particles / size linear chains of `size` unit masses joined by length-0 springs (k = OMEGA^2/2), no soft
    force; chain c along x at y = c."""
    system = openmm.System()
    springs = openmm.HarmonicBondForce()
    springs.setForceGroup(fpu_chain.STIFF_GROUP)
    positions = []
    for c in range(particles // size):
        for k in range(size):
            i = system.addParticle(1.0)
            positions.append(openmm.Vec3(0.1 * k, c, 0.0))
            if k:
                springs.addBond(i - 1, i, 0.0, OMEGA * OMEGA / 2)
    system.addForce(springs)
    return system, positions


def component_scaling(particles, sizes, steps, repeats):
    """Mode work per step against sum_c n_c^2 (part b)."""
    rows = []
    for size in sizes:
        system, positions = stiff_chains(particles, size)
        row = {"n_c": size, "components": particles // size, "sum_nc2": particles * size}
        for friction in (0.0, 1.0):
            print(f"  chains of {size}, friction {friction:g}", file=sys.stderr, flush=True)
            integrator = openmmflavors.StochasticImpulseIntegrator(300, friction, H, {fpu_chain.STIFF_GROUP})
            integrator.setRandomNumberSeed(1)
            row[f"step_us_friction{friction:g}"] = per_step_us(system, integrator, positions, steps, repeats)
        rows.append(row)
    slopes = {}
    for name, smallest in (("general_path", COMPILED_MAX + 1), ("n_c_32_up", 32)):
        fitted = [r for r in rows if r["n_c"] >= smallest]
        if len(fitted) >= 2:
            for friction in ("0", "1"):
                x = np.log([r["sum_nc2"] for r in fitted])
                y = np.log([r[f"step_us_friction{friction}"] for r in fitted])
                slopes[f"{name}_friction{friction}"] = float(np.polyfit(x, y, 1)[0])
    return {"particles": particles, "rows": rows, "loglog_slopes": slopes}


def main():
    p = scene.parser(__doc__, "sim_step_cost", quick_help="a few seconds: 100 chains, short batches")
    p.add_argument("--chains", type=int, default=1667)
    p.add_argument("--particles", type=int, default=PARTICLES, help="particles of part (b)")
    args = p.parse_args()
    chains = 100 if args.quick else args.chains
    steps, repeats = (20, 2) if args.quick else (200, 5)
    positions = fpu_chain.chain_positions(M, OMEGA, chains)
    full = fpu_chain.fpu_system(M, OMEGA, chains)
    stiff_only = fpu_chain.fpu_system(M, OMEGA, chains)
    for k in reversed(range(stiff_only.getNumForces())):
        if stiff_only.getForce(k).getForceGroup() != fpu_chain.STIFF_GROUP:
            stiff_only.removeForce(k)
    soft_only = openmm.VerletIntegrator(1e-4)
    soft_only.setIntegrationForceGroups({fpu_chain.SOFT_GROUP})
    print(f"measuring: {chains} chains, best of {repeats} x {steps} steps", file=sys.stderr, flush=True)
    soft = per_step_us(full, soft_only, positions, steps, repeats)
    rows, results = [], {"chains": chains, "particles": 2 * M * chains, "soft_evaluation_us": soft, "runs": {}}
    for friction in (0.0, 1.0):
        for splitting in ("Strang", "LieTrotter"):
            def make():
                integrator = openmmflavors.StochasticImpulseIntegrator(300, friction, H, {fpu_chain.STIFF_GROUP})
                integrator.setSplitting(getattr(openmmflavors.StochasticImpulseIntegrator, splitting))
                integrator.setRandomNumberSeed(1)
                return integrator
            print(f"  {splitting}, friction {friction:g}", file=sys.stderr, flush=True)
            step = per_step_us(full, make(), positions, steps, repeats)
            modes = per_step_us(stiff_only, make(), positions, steps, repeats)
            ratio = (step - modes) / soft
            results["runs"][f"{splitting}_friction{friction:g}"] = {"step_us": step, "mode_work_us": modes,
                                                                   "soft_evaluations_beyond_mode_work": ratio}
            rows.append([splitting, f"{friction:g}", f"{step:.0f}", f"{modes:.0f}", f"{soft:.0f}", f"{ratio:.2f}"])
    scene.table(f"SIM step cost, {chains} FPU chains, Reference (target: (step - mode work) / soft <= 1.3)",
                [("splitting", 10, ""), ("friction", 8, ""), ("step us", 9, ""), ("mode work us", 12, ""),
                 ("soft eval us", 12, ""), ("(step - modes) / soft", 21, "")], rows)

    sizes = [2, 4, 8, 16] if args.quick else COMPONENT_SIZES
    particles = 768 if args.quick else args.particles
    scaling = component_scaling(particles, sizes, steps, repeats)
    results["component_scaling"] = scaling
    scene.table(f"Mode work against component size, {particles} particles in stiff chains of n_c, Reference",
                [("n_c", 5, ""), ("components", 10, ""), ("sum n_c^2", 10, ""), ("us, friction 0", 15, ""),
                 ("us, friction 1", 15, ""), ("ns / n_c^2 unit, fr. 0", 22, "")],
                [[r["n_c"], r["components"], r["sum_nc2"], f"{r['step_us_friction0']:.1f}",
                  f"{r['step_us_friction1']:.1f}", f"{1e3 * r['step_us_friction0'] / r['sum_nc2']:.2f}"]
                 for r in scaling["rows"]])
    for name, slope in scaling["loglog_slopes"].items():
        print(f"log-log slope of the step time against sum n_c^2, {name}: {slope:.2f}")
    print("(per particle work, the gathering and the noise, is O(N); the products with the eigenvectors O(sum n_c^2))")

    def plot(path):
        plt = scene.pyplot()
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 3.6))
        names = list(results["runs"])
        ax.bar(names, [results["runs"][n]["mode_work_us"] for n in names], label="mode work")
        ax.bar(names, [results["runs"][n]["step_us"] - results["runs"][n]["mode_work_us"] for n in names],
               bottom=[results["runs"][n]["mode_work_us"] for n in names], label="rest of the step")
        ax.axhline(soft, color="k", ls="--", lw=1, label="one soft evaluation")
        ax.set_ylabel("µs per step")
        ax.legend(fontsize=7)
        ax.tick_params(axis="x", labelsize=7)
        ax.set_title(f"(a) {chains} FPU chains", fontsize=9)
        work = [r["sum_nc2"] for r in scaling["rows"]]
        for friction, marker in (("0", "o"), ("1", "s")):
            bx.loglog(work, [r[f"step_us_friction{friction}"] for r in scaling["rows"]], marker + "-",
                      label=f"friction {friction}/ps")
        for r in scaling["rows"]:
            bx.annotate(f"{r['n_c']}", (r["sum_nc2"], r["step_us_friction0"]), fontsize=6,
                        textcoords="offset points", xytext=(2, -8))
        reference = scaling["rows"][-1]
        bx.loglog(work, [reference["step_us_friction0"] * w / reference["sum_nc2"] for w in work], "k:", lw=1,
                  label="∝ Σ n_c²")
        bx.set_xlabel("Σ n_c² (labels: n_c)")
        bx.set_ylabel("µs per step (stiff only)")
        bx.set_title(f"(b) mode work, {particles} particles in stiff chains", fontsize=9)
        bx.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(path, dpi=90)

    scene.save_outputs(args.out, "sim_step_cost", results, plot)


if __name__ == "__main__":
    main()

"""Cost of one StochasticImpulseIntegrator step against one soft-group force evaluation plus its mode work, and how
the mode work grows with the size of the stiff components.

(a) The mode work (the exact stiff flow of every component, and its noise with friction) is measured as the step of
    the same integrator on the same chains with the soft forces removed; the soft evaluation as the step of a
    VerletIntegrator restricted to the soft group.  Reference platform, FPU chains (FLAVORS paper eq. 6.7).
(b) Mode work against sum_c n_c^2: PARTICLES particles in stiff linear chains of n_c particles each (HarmonicBondForce
    of length 0 between neighbours, no soft force), n_c from 2 to 256, friction 0 and 1/ps; the log-log slope of the
    step time against sum_c n_c^2 = PARTICLES n_c over the sizes that take the general path (n_c > 6: products with
    the eigenvectors, O(n_c^2) per component) and over n_c >= 32, where those products dominate.

    PYTHONPATH=build/python .venv/bin/python benchmarks/sim_step_cost.py [--chains N] [--quick] [--out DIR]
"""
import sys

import numpy as np
import openmm

from flavorbench import reporting
from flavorbench.runners import best_time, sim, start_context, verlet
from flavorbench.systems import SOFT_GROUP, STIFF_GROUP, chain_positions, fpu_system

OMEGA, M, H = 200.0, 3, 0.005
PARTICLES = 6144  # divisible by every component size of part (b)
COMPONENT_SIZES = [2, 3, 4, 6, 8, 16, 32, 64, 128, 256]
COMPILED_MAX = 6  # components of up to 6 particles run a flow compiled for their size


def per_step_us(system, make, positions, steps, repeats):
    """Best of `repeats` batches of `steps` steps after five untimed ones, in microseconds per step."""
    integrator = make()
    context = start_context(system, integrator, 0.0, positions)
    integrator.step(5)
    return 1e6 * best_time(lambda: (context, integrator), steps, repeats)[0] / steps


def stiff_chains(particles, size):
    """particles / size linear chains of `size` unit masses joined by length-0 springs (k = OMEGA^2/2), no soft
    force; chain c along x at y = c."""
    system = openmm.System()
    springs = openmm.HarmonicBondForce()
    springs.setForceGroup(STIFF_GROUP)
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
            row[f"step_us_friction{friction:g}"] = per_step_us(
                system, lambda: sim(H, temperature=300, friction=friction, seed=1), positions, steps, repeats)
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
    p = reporting.parser(__doc__, "sim_step_cost", quick_help="a few seconds: 100 chains, short batches")
    p.add_argument("--chains", type=int, default=1667)
    p.add_argument("--particles", type=int, default=PARTICLES, help="particles of part (b)")
    args = p.parse_args()
    chains = 100 if args.quick else args.chains
    steps, repeats = (20, 2) if args.quick else (200, 5)
    positions = chain_positions(M, OMEGA, chains)
    full = fpu_system(M, OMEGA, chains)
    stiff_only = fpu_system(M, OMEGA, chains)
    for k in reversed(range(stiff_only.getNumForces())):
        if stiff_only.getForce(k).getForceGroup() != STIFF_GROUP:
            stiff_only.removeForce(k)
    print(f"measuring: {chains} chains, best of {repeats} x {steps} steps", file=sys.stderr, flush=True)
    soft = per_step_us(full, lambda: verlet(1e-4, {SOFT_GROUP}), positions, steps, repeats)
    rows, results = [], {"chains": chains, "particles": 2 * M * chains, "soft_evaluation_us": soft, "runs": {}}
    for friction in (0.0, 1.0):
        for splitting in ("Strang", "LieTrotter"):
            def make():
                return sim(H, splitting, temperature=300, friction=friction, seed=1)
            print(f"  {splitting}, friction {friction:g}", file=sys.stderr, flush=True)
            step = per_step_us(full, make, positions, steps, repeats)
            modes = per_step_us(stiff_only, make, positions, steps, repeats)
            ratio = (step - modes) / soft
            results["runs"][f"{splitting}_friction{friction:g}"] = {"step_us": step, "mode_work_us": modes,
                                                                   "soft_evaluations_beyond_mode_work": ratio}
            rows.append([splitting, f"{friction:g}", f"{step:.0f}", f"{modes:.0f}", f"{soft:.0f}", f"{ratio:.2f}"])
    reporting.table(f"SIM step cost, {chains} FPU chains, Reference (target: (step - mode work) / soft <= 1.3)",
                [("splitting", 10, ""), ("friction", 8, ""), ("step us", 9, ""), ("mode work us", 12, ""),
                 ("soft eval us", 12, ""), ("(step - modes) / soft", 21, "")], rows)

    sizes = [2, 4, 8, 16] if args.quick else COMPONENT_SIZES
    particles = 768 if args.quick else args.particles
    scaling = component_scaling(particles, sizes, steps, repeats)
    results["component_scaling"] = scaling
    reporting.table(f"Mode work against component size, {particles} particles in stiff chains of n_c, Reference",
                [("n_c", 5, ""), ("components", 10, ""), ("sum n_c^2", 10, ""), ("us, friction 0", 15, ""),
                 ("us, friction 1", 15, ""), ("ns / n_c^2 unit, fr. 0", 22, "")],
                [[r["n_c"], r["components"], r["sum_nc2"], f"{r['step_us_friction0']:.1f}",
                  f"{r['step_us_friction1']:.1f}", f"{1e3 * r['step_us_friction0'] / r['sum_nc2']:.2f}"]
                 for r in scaling["rows"]])
    for name, slope in scaling["loglog_slopes"].items():
        print(f"log-log slope of the step time against sum n_c^2, {name}: {slope:.2f}")
    print("(per particle work, the gathering and the noise, is O(N); the products with the eigenvectors O(sum n_c^2))")

    def plot(path):
        plt = reporting.pyplot()
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.4))
        fig.suptitle("StochasticImpulseIntegrator step cost, Reference platform: mode work (exact stiff flow and noise) "
                     "against the rest of the step\nand one soft-group force evaluation; friction γ in ps⁻¹",
                     fontsize=10)
        names = list(results["runs"])
        ax.bar(names, [results["runs"][n]["mode_work_us"] for n in names], label="mode work")
        ax.bar(names, [results["runs"][n]["step_us"] - results["runs"][n]["mode_work_us"] for n in names],
               bottom=[results["runs"][n]["mode_work_us"] for n in names], label="rest of the step")
        ax.axhline(soft, color="k", ls="--", lw=1, label="one soft evaluation")
        ax.set_ylabel("wall time per step (µs)")
        ax.legend(fontsize=7)
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels([n.replace("_friction", ", γ = ") for n in names], fontsize=7)
        ax.set_title(f"(a) {chains} FPU chains (FLAVORS paper eq. 6.7): one step, split", fontsize=9)
        work = [r["sum_nc2"] for r in scaling["rows"]]
        for friction, marker in (("0", "o"), ("1", "s")):
            bx.loglog(work, [r[f"step_us_friction{friction}"] for r in scaling["rows"]], marker + "-",
                      label=f"friction γ = {friction} ps⁻¹")
        for r in scaling["rows"]:
            bx.annotate(f"{r['n_c']}", (r["sum_nc2"], r["step_us_friction0"]), fontsize=6,
                        textcoords="offset points", xytext=(2, -8))
        reference = scaling["rows"][-1]
        bx.loglog(work, [reference["step_us_friction0"] * w / reference["sum_nc2"] for w in work], "k:", lw=1,
                  label="∝ Σ n_c²")
        bx.set_xlabel("Σ_c n_c², n_c particles per stiff chain (point labels: n_c)")
        bx.set_ylabel("wall time per step, stiff forces only (µs)")
        bx.set_title(f"(b) mode work against the chain size, {particles} particles in stiff chains", fontsize=9)
        bx.legend(fontsize=7)
        fig.tight_layout()
        reporting.save_figure(fig, path, 90)

    reporting.save_outputs(args.out, "sim_step_cost", results, plot)


if __name__ == "__main__":
    main()

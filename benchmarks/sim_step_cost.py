"""Cost of one StochasticImpulseIntegrator step against one soft-group force evaluation plus its mode work.

The mode work (the exact stiff flow of every component, and its noise with friction) is measured as the step of the
same integrator on the same chains with the soft forces removed; the soft evaluation as the step of a
VerletIntegrator restricted to the soft group.  Reference platform, FPU chains (FLAVORS paper eq. 6.7).

    PYTHONPATH=build/python /usr/bin/python3 benchmarks/sim_step_cost.py [--chains N] [--quick] [--out DIR]
"""
import os
import sys
import time

import openmm

import openmmflavors

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "common"))
import fpu_chain  # noqa: E402
import scene  # noqa: E402

OMEGA, M, H = 200.0, 3, 0.005


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


def main():
    p = scene.parser(__doc__, "sim_step_cost", quick_help="a few seconds: 100 chains, short batches")
    p.add_argument("--chains", type=int, default=1667)
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

    def plot(path):
        plt = scene.pyplot()
        fig, ax = plt.subplots(figsize=(6, 3.2))
        names = list(results["runs"])
        ax.bar(names, [results["runs"][n]["mode_work_us"] for n in names], label="mode work")
        ax.bar(names, [results["runs"][n]["step_us"] - results["runs"][n]["mode_work_us"] for n in names],
               bottom=[results["runs"][n]["mode_work_us"] for n in names], label="rest of the step")
        ax.axhline(soft, color="k", ls="--", lw=1, label="one soft evaluation")
        ax.set_ylabel("µs per step")
        ax.legend(fontsize=7)
        ax.tick_params(axis="x", labelsize=7)
        fig.tight_layout()
        fig.savefig(path, dpi=90)

    scene.save_outputs(args.out, "sim_step_cost", results, plot)


if __name__ == "__main__":
    main()

"""Wall-clock speed of peers timed interleaved: every peer steps the same simulated time in turn, round after round,
so that a change of the machine's load hits them alike, and each peer's speed is read against the first's of the
same round."""
import time

import numpy as np
import openmm


def interleaved_ns_per_day(peers, rounds, round_ps, warmup_steps=10, report=print):
    """Times `peers`, a list of (name, step_fs, integrator, context), each Context set up, over `rounds` rounds of
    round_ps each (after one untimed round of warmup_steps steps), the order rotated by one peer each round.  A peer
    whose step raises an OpenMMException drops out, its failure recorded.  `report(line)` gets one line per round.

    Returns {"ns_per_day": {name: [per round]}, "median_ns_per_day": {name: median},
    "median_ratio_to_first": {name: median over the rounds of its ns/day over the first peer's of the same round},
    "failed": {name: {"failed_in_steps": [first, last], "error": message}}}; the ratios need the first peer to
    have run every round."""
    if rounds < 1:
        raise ValueError(f"rounds must be at least 1 (got {rounds})")
    if round_ps <= 0:
        raise ValueError(f"round_ps must be positive (got {round_ps})")
    names = [peer[0] for peer in peers]
    speeds = {name: [] for name in names}
    steps_done = {name: 0 for name in names}
    failed = {}
    for round_ in range(rounds + 1):  # round 0: warm-up, not timed
        order = peers[round_ % len(peers):] + peers[:round_ % len(peers)]
        for name, step_fs, integrator, context in order:
            if name in failed:
                continue
            steps = warmup_steps if round_ == 0 else max(1, int(round(round_ps * 1000 / step_fs)))
            try:
                start = time.perf_counter()
                integrator.step(steps)
                context.getState(getPositions=True)  # waits for a device that steps asynchronously
                seconds = time.perf_counter() - start
            except openmm.OpenMMException as error:
                failed[name] = {"failed_in_steps": [steps_done[name] + 1, steps_done[name] + steps],
                                "error": str(error)}
                report(f"{name} failed in steps {steps_done[name] + 1}-{steps_done[name] + steps}: {error}")
                continue
            steps_done[name] += steps
            if round_:
                speeds[name].append(steps * step_fs * 1e-6 / (seconds / 86400))
        if round_:
            report(f"round {round_}/{rounds}: " +
                   ", ".join(f"{name} {speeds[name][-1]:.2f}" for name in names if name not in failed) + " ns/day")
    first = names[0]
    ratios = {}
    if first not in failed:
        ratios = {name: float(np.median(np.array(speeds[name]) / np.array(speeds[first])))
                  for name in names[1:] if name not in failed}
    return {"ns_per_day": {n: v for n, v in speeds.items() if n not in failed},
            "median_ns_per_day": {n: float(np.median(v)) for n, v in speeds.items() if n not in failed},
            "median_ratio_to_first": ratios, "failed": failed}

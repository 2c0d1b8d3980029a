"""Time series of molecular runs: the production frames of a run, and their block-average error bars."""
import math
import time
from collections import namedtuple

import numpy as np
import openmm as mm
import openmm.unit as unit

Frame = namedtuple("Frame", "state positions velocities potential_energy")
Frame.__doc__ = "One production frame: the State, positions (nm), velocities (nm/ps), potential energy (kJ/mol)."


class ProductionFrames:
    """Iterating steps the integrator `steps` steps in chunks of max(1, steps // frames) and yields a Frame after each
    chunk; `steps_done` and `elapsed` (wall seconds of stepping only) grow as it goes.  A non-finite state raises
    OpenMMException("non-finite state")."""

    def __init__(self, context, integrator, steps, frames):
        self.context, self.integrator = context, integrator
        self.steps, self.interval = steps, max(1, steps // frames)
        self.steps_done, self.elapsed = 0, 0.0

    def __iter__(self):
        while self.steps_done < self.steps:
            begin = time.perf_counter()
            self.integrator.step(self.interval)
            self.elapsed += time.perf_counter() - begin
            self.steps_done += self.interval
            state = self.context.getState(getPositions=True, getVelocities=True, getEnergy=True,
                                          enforcePeriodicBox=False)
            q = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
            v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
            pe = state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)
            if not np.all(np.isfinite(q)) or not math.isfinite(pe):
                raise mm.OpenMMException("non-finite state")
            yield Frame(state, q, v, pe)

    def ns_per_day(self, step_fs):
        """Simulated ns per day of stepping, from the steps done so far."""
        return self.steps_done * step_fs * 1e-6 / self.elapsed * 86400


def block_error(series, blocks):
    """Mean of a correlated time series and the standard error of its `blocks` block means (nan for < 2 blocks).

    The blocks must be longer than the series' correlation time for the error to be honest."""
    series = np.asarray(series, dtype=float)
    usable = len(series) // blocks * blocks
    if usable < blocks or blocks < 2:
        return float(np.mean(series)), float("nan")
    means = series[:usable].reshape(blocks, -1).mean(axis=1)
    return float(np.mean(series)), float(np.std(means, ddof=1) / math.sqrt(blocks))


def add_block_errors(record, series, blocks):
    """record[key], record[key + "_error"] = block_error(values, blocks) for each key, values of series."""
    for key, values in series.items():
        record[key], record[key + "_error"] = block_error(values, blocks)

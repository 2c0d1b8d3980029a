"""Error bars of time series from molecular runs: block averages."""
import math

import numpy as np


def block_error(series, blocks):
    """Mean of a correlated time series and the standard error of its `blocks` block means (nan for < 2 blocks).

    The blocks must be longer than the series' correlation time for the error to be honest."""
    series = np.asarray(series, dtype=float)
    usable = len(series) // blocks * blocks
    if usable < blocks or blocks < 2:
        return float(np.mean(series)), float("nan")
    means = series[:usable].reshape(blocks, -1).mean(axis=1)
    return float(np.mean(series)), float(np.std(means, ddof=1) / math.sqrt(blocks))

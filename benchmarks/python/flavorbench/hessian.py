"""Force-constant matrices from OpenMM's forces by central differences."""

import itertools

import numpy as np
import openmm.unit as unit

# The CPU platform computes nonbonded forces in single precision: with steps of 2e-5 nm the differences read their
# rounding (alanine dipeptide's largest soft stiffness along its Drude modes came out 1.96 k instead of Reference's
# 0.54 k); with 1e-3 nm (and 2e-4) the CPU platform agrees with Reference to 1e-3 k.
STEP_NM = 1e-3


def hessian_over(context, x, particles, groups, step=STEP_NM, progress=None):
    """The Hessian (kJ/mol/nm^2) of the forces of the force groups `groups` (a bit mask) over the coordinates of
    `particles` (3n x 3n, particle-major), the other particles held at x (nm), by central differences of step nm.
    progress(columns done, columns) is called after each column.  The Context is left at x."""
    def forces(positions):
        context.setPositions(positions)
        return context.getState(getForces=True, groups=groups).getForces(asNumpy=True).value_in_unit(
            unit.kilojoule_per_mole / unit.nanometer)[particles]

    x = np.asarray(x, dtype=float)
    columns = 3 * len(particles)
    hessian = np.zeros((columns, columns))
    for column, (j, axis) in enumerate(itertools.product(range(len(particles)), range(3))):
        plus, minus = x.copy(), x.copy()
        plus[particles[j], axis] += step
        minus[particles[j], axis] -= step
        hessian[:, column] = -(forces(plus) - forces(minus)).ravel() / (2 * step)
        if progress is not None:
            progress(column + 1, columns)
    context.setPositions(x)
    return 0.5 * (hessian + hessian.T)

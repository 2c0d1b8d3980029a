"""Argument conversion shared by the wrapped integrators.

Every number may be a Python number, a numpy scalar (np.int64, np.float32, ...) or, where OpenMM's integrators take
one, a Quantity; each is converted to the plain int or float the C++ API takes.
"""
import numbers

import openmm.unit as unit


def toFloat(value, name):
    """Return a real number (Python or numpy) as a float; anything else is returned as is, for C++ to reject."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    return value


def toInt(value, name):
    """Return an integer (Python or numpy) as an int; a float or anything else raises TypeError naming name."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)
    raise TypeError(f"{name} = {value!r} is not allowed; {name} must be an integer")


def toBool(value, name):
    """Return a bool (Python or numpy) as a bool."""
    # numpy's bool is numpy.bool_ (named numpy.bool from numpy 2 on), no subclass of bool.
    if isinstance(value, bool) or (type(value).__module__ == "numpy" and type(value).__name__ in ("bool_", "bool")):
        return bool(value)
    raise TypeError(f"{name} = {value!r} is not allowed; {name} must be True or False")


def toIntList(values, name):
    """Return a sequence of integers (Python or numpy, or a numpy array) as a list of ints."""
    try:
        items = list(values)
    except TypeError:
        raise TypeError(f"{name} = {values!r} is not allowed; give a list of particle indices") from None
    return [toInt(item, name) for item in items]


def stripUnits(value, target, name):
    """Return value as a float in the unit `target`; plain numbers are taken to be in that unit already."""
    if unit.is_quantity(value):
        if not value.unit.is_compatible(target):
            raise TypeError(f"{name}: {value} is not compatible with {target}")
        return toFloat(value.value_in_unit(target), name)
    return toFloat(value, name)


def groupMask(groups, name):
    """Return a force-group bitmask (a signed 32-bit int) from an int bitmask or a collection of group numbers."""
    if isinstance(groups, numbers.Integral) and not isinstance(groups, bool):
        groups = int(groups)
        if not -(1 << 31) <= groups < (1 << 32):
            raise ValueError(f"{name} = {groups} is not allowed; a bitmask may only use bits 0..31 (groups 0..31)")
        mask = groups
    elif isinstance(groups, (set, frozenset, list, tuple, range)) or type(groups).__name__ == "ndarray":
        mask = 0
        for group in groups:
            if (
                not isinstance(group, numbers.Integral)
                or isinstance(group, bool)
                or type(group).__name__ == "bool_"
                or not 0 <= int(group) <= 31
            ):
                raise ValueError(f"{name}: group {group!r} is not allowed; force groups are integers 0..31")
            mask |= 1 << int(group)
    else:
        raise TypeError(f"{name} = {groups!r} is not allowed; give a bitmask int or a set of group numbers 0..31")
    if mask >= (1 << 31):
        mask -= 1 << 32
    return mask

"""Argument conversion shared by the wrapped integrators."""
import openmm.unit as unit


def stripUnits(value, target, name):
    """Return value as a float in the unit `target`; plain numbers are taken to be in that unit already."""
    if unit.is_quantity(value):
        if not value.unit.is_compatible(target):
            raise TypeError(f"{name}: {value} is not compatible with {target}")
        return value.value_in_unit(target)
    return value


def groupMask(groups, name):
    """Return a force-group bitmask (a signed 32-bit int) from an int bitmask or a collection of group numbers."""
    if isinstance(groups, (set, frozenset, list, tuple)):
        mask = 0
        for group in groups:
            if not isinstance(group, int) or isinstance(group, bool) or not 0 <= group <= 31:
                raise ValueError(f"{name}: group {group!r} is not allowed; force groups are integers 0..31")
            mask |= 1 << group
    elif isinstance(groups, int) and not isinstance(groups, bool):
        if not -(1 << 31) <= groups < (1 << 32):
            raise ValueError(f"{name} = {groups} is not allowed; a bitmask may only use bits 0..31 (groups 0..31)")
        mask = groups
    else:
        raise TypeError(f"{name} = {groups!r} is not allowed; give a bitmask int or a set of group numbers 0..31")
    if mask >= (1 << 31):
        mask -= 1 << 32
    return mask

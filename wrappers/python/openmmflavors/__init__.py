"""
openmmflavors: multiscale integrators for stiff systems in OpenMM.

FlavorIntegrator runs flow-averaging integrators (FLAVORS): the stiff force groups act for a microstep in every
mesostep, so the step size is set by the slow time scale.  StochasticImpulseIntegrator runs stochastic impulse
methods (SIMs): a quadratic stiff potential is integrated by its exact flow with exact friction and noise.  Importing this package loads the plugin's kernels for
the Reference and CPU platforms.
"""
import os as _os

import openmm as _openmm

_here = _os.path.dirname(_os.path.abspath(__file__))
# OpenMM's own plugins (the CPU platform among them) are loaded by `import openmm`; ours must come after them.
for _name in ("libOpenMMFlavorsReference.so", "libOpenMMFlavorsCPU.so"):
    _openmm.Platform.loadPluginLibrary(_os.path.join(_here, "plugins", _name))

from .openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator  # noqa: E402

_integratorClasses = [FlavorIntegrator, StochasticImpulseIntegrator]


def _asPluginIntegrator(integrator):
    """Return integrator as the plugin class it really is, taking over ownership; otherwise return it unchanged."""
    if integrator is None:
        return None
    for cls in _integratorClasses:
        cast = cls._cast(integrator)
        if cast is not None:
            cast.thisown = integrator.thisown
            integrator.thisown = False
            return cast
    return integrator


def _patchSerializer():
    # openmm.XmlSerializer knows only OpenMM's integrators and hands back a bare Integrator for ours; wrap its
    # two factories so deserialize(), clone(), copy and pickle give back the plugin's classes.
    serializer = _openmm.XmlSerializer
    if getattr(serializer, "_openmmflavorsPatched", False):
        return
    deserialize, clone = serializer._deserializeIntegrator, serializer._cloneIntegrator
    serializer._deserializeIntegrator = staticmethod(lambda text: _asPluginIntegrator(deserialize(text)))
    serializer._cloneIntegrator = staticmethod(lambda obj: _asPluginIntegrator(clone(obj)))
    serializer._openmmflavorsPatched = True


_patchSerializer()

__all__ = ["FlavorIntegrator", "StochasticImpulseIntegrator"]

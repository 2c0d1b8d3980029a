"""
openmmflavors: multiscale integrators for stiff systems in OpenMM.

FlavorIntegrator runs flow-averaging integrators (FLAVORS): the stiff force groups act for a microstep in every
mesostep, so the step size is set by the slow time scale.  StochasticImpulseIntegrator runs stochastic impulse
methods (SIMs): a quadratic stiff potential is integrated by its exact flow with exact friction and noise.  Importing
this package loads the plugin's kernels for the Reference, CPU, OpenCL and CUDA platforms.
"""
import os as _os

import openmm as _openmm

from . import _config

_here = _os.path.dirname(_os.path.abspath(__file__))


def _hasPlatform(name):
    return any(_openmm.Platform.getPlatform(i).getName() == name for i in range(_openmm.Platform.getNumPlatforms()))


# Installed with pip, the kernel plugins sit in OpenMM's own plugin directory and `import openmm` has loaded them; then
# there is nothing to load.  Otherwise (a build tree, `make install`) they are loaded from the package's plugin folder.
def _kernelsRegistered():
    return _openmm.Platform.getPlatformByName("Reference").supportsKernels(["IntegrateFlavorStep"])


if not _kernelsRegistered():
    # `import openmm` loads OpenMM's plugins from OPENMM_PLUGIN_DIR; if that points elsewhere, the CPU platform is
    # missing, and our CPU kernels would have nothing to register with.
    if not _hasPlatform("CPU"):
        _cpu = _os.path.join(_config.OPENMM_PLUGIN_DIR, "libOpenMMCPU.so")
        if _os.path.exists(_cpu):
            _openmm.Platform.loadPluginLibrary(_cpu)
    # Ours must come after OpenMM's own plugins.
    _pluginDir = _os.path.normpath(_os.path.join(_here, _config.PLUGIN_DIR_FROM_PACKAGE))
    for _name in ("libOpenMMFlavorsReference.so", "libOpenMMFlavorsCPU.so"):
        _openmm.Platform.loadPluginLibrary(_os.path.join(_pluginDir, _name))
    # The GPU kernels exist where the build found the platform's headers; each is loaded only where OpenMM has that
    # platform (an OpenCL driver; for CUDA an NVIDIA driver, without which its library cannot even be loaded).
    for _platform, _name in (("OpenCL", "libOpenMMFlavorsOpenCL.so"), ("CUDA", "libOpenMMFlavorsCUDA.so")):
        if _hasPlatform(_platform) and _os.path.exists(_os.path.join(_pluginDir, _name)):
            _openmm.Platform.loadPluginLibrary(_os.path.join(_pluginDir, _name))

from .openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator  # noqa: E402
from ._warnings import (FlavorsWarning, PlanarAngleGroupWarning, ResonanceWarning, StiffGroupWarning,  # noqa: E402
                        UnitlessStepWarning)

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

__all__ = ["FlavorIntegrator", "StochasticImpulseIntegrator", "FlavorsWarning", "UnitlessStepWarning",
           "StiffGroupWarning", "PlanarAngleGroupWarning", "ResonanceWarning"]

"""The GPU backend (OpenCL, CUDA) in double precision follows the Reference platform on flexible water: 45 steps of the Langevin
nonintrusive FLAVOR (bonds and angles stiff, delta = 1 fs, tau = 0.25 fs) on 100 TIP3P waters, without cutoff and with
PME.  The noise is the same counter-based stream on both platforms, so what is left is rounding: OpenMM's GPU
platforms sum forces in fixed point (2^-32 kJ/mol/nm).  Measured on OpenCL (PoCL): 3.1e-8 nm without cutoff, 2.1e-8 nm
with PME.  Skipped for each platform OpenMM does not have."""
import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit
import pytest

from openmmflavors import FlavorIntegrator

import conftest


@pytest.mark.parametrize("gpu", ["OpenCL", "CUDA"])
@pytest.mark.parametrize("method, tolerance", [(app.NoCutoff, 1e-7), (app.PME, 1e-5)])
def test_the_nonintrusive_flavor_on_a_gpu_platform_follows_the_reference_platform(method, tolerance, gpu):
    if gpu not in conftest.GPU_PLATFORMS:
        pytest.skip(f"OpenMM has no {gpu} platform here")
    forcefield = app.ForceField("tip3p.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(forcefield, model="tip3p", numAdded=100)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=method, nonbondedCutoff=0.7 * unit.nanometer,
                                     rigidWater=False, constraints=None)
    for force in system.getForces():
        force.setForceGroup(1 if isinstance(force, (openmm.HarmonicBondForce, openmm.HarmonicAngleForce)) else 0)
    start = openmm.Context(system, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("Reference"))
    start.setPositions(modeller.positions)
    openmm.LocalEnergyMinimizer.minimize(start, 10, 100)
    start.setVelocitiesToTemperature(300 * unit.kelvin, 3)
    state = start.getState(getPositions=True, getVelocities=True)
    positions = {}
    for platform, properties in (("Reference", {}), (gpu, {"Precision": "double"})):
        integrator = FlavorIntegrator(1 * unit.femtoseconds, 0.25 * unit.femtoseconds, {1})
        integrator.setTemperature(300 * unit.kelvin)
        integrator.setFriction(1 / unit.picosecond)
        integrator.setRandomNumberSeed(7)
        context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName(platform), properties)
        context.setPositions(state.getPositions())
        context.setVelocities(state.getVelocities())
        integrator.step(45)
        positions[platform] = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(
            unit.nanometer)
    moved = np.abs(positions["Reference"] - np.array(state.getPositions().value_in_unit(unit.nanometer))).max()
    assert moved > 1e-3  # the molecules moved
    assert np.abs(positions["Reference"] - positions[gpu]).max() <= tolerance

#!/usr/bin/env python3
"""Flexible TIP3P water (501 molecules, 1,503 atoms, PME) on the CPU platform: the artificial FLAVOR against the
integrator a practitioner would pick, LangevinMiddleIntegrator on flexible water at the longest step it stands.

Peers (Langevin, 300 K, friction 1/ps), the default ("practitioner") set:
  - LangevinMiddleIntegrator, flexible water, 0.25 fs (the reference), 1, 1.5, 2 and 2.5 fs;
  - FlavorIntegrator, ArtificialProjected, O-H bonds and H-O-H angles stiff (frozen between microsteps), thermostat
    in the middle of the microstep (Middle), tau = 0.5 fs, delta = 4, 6, 7, 8 and 10 fs; at delta = 6 fs also
    tau = 0.25 and 1 fs, and the thermostat at the edges of the mesostep (the paper's placement, no "Middle").
--set earlier runs the scene's earlier peers instead (the reference, LangevinMiddle 0.5 fs, rigid water at 2 fs,
MTSLangevin 2 fs / 4, the Nonintrusive, Artificial and ArtificialProjected averagings at delta = 2-4 fs), --set all
both.

Observables, each with a block-average error bar (the standard error of 5 block means): mean O-H length and its
spread, mean H-O-H angle and its spread, potential energy per molecule, kinetic temperature of O and of H
separately, and g_OO(r) (the first-peak height).  With several --seeds every peer is run once per seed (its own start)
and the run-to-run spread is reported too.  Dynamics, for the reference, LangevinMiddle 2 fs and the FLAVORs with
tau = 0.5 fs and delta = 4, 6, 7, 8, 10 fs: the oxygens' self-diffusion coefficient from their mean-squared displacement
(unwrapped), and after the production a segment saved every 2 fs (every mesostep for a FLAVOR) whose O-H
bond-length velocity, the hydrogens' velocity and the molecules' angular velocity give power spectra (the O-H
stretch band, the librations).

Speed: every peer's Context lives through the whole production, which runs in --rounds interleaved rounds (each peer in
turn advances production/rounds ps, the order reversed every other round), so machine load falls on all peers alike;
ns/day counts the wall time of integrator.step only.

    PYTHONPATH=build/python .venv/bin/python examples/flexible_water/flexible_water.py [--quick] [--out DIR]
        [--start PS] [--equilibration PS] [--production PS] [--threads N] [--seeds S ...] [--set SET]
        [--peers NAME ...]

--peers runs only the peers of the set whose names contain one of the given strings (the first of them is the
reference for the comparisons).

Every peer of one seed starts from the same state: minimized, then --start ps of LangevinMiddle (flexible, 0.5 fs);
each peer then equilibrates for --equilibration ps with its own integrator before --production ps of measurement.

Outputs: DIR/flexible_water.json (every number), DIR/flexible_water.png (observables and speed) and
DIR/flexible_water_dynamics.png (diffusion and spectra).
"""
import argparse
import math
import os
import textwrap
import time

import numpy as np
import openmm as mm
import openmm.app as app
import openmm.unit as unit

import openmmflavors
from flavorbench import reporting
from flavorbench.runners import KB
from flavorbench.solvation import compress_to_volume, water_volume
from flavorbench.systems import assign_force_groups
from flavorbench.timeseries import ProductionFrames, add_block_errors, block_error

TEMPERATURE = 300.0  # K
FRICTION = 1.0  # 1/ps
BOND_GROUP, ANGLE_GROUP = 1, 2
BLOCKS = 5
# speed of light in cm/ps: a frequency in 1/ps over it is a wavenumber in 1/cm.
C_CM_PER_PS = 2.99792458e-2
# The observables that decide whether a peer stays within the reference's error bars.
CHECKED = ("oh_mean", "oh_sd", "angle_mean", "angle_sd", "pe_per_molecule", "T_O", "T_H", "g_OO_peak")
# A peer is within the reference's error bars when each of them is within WITHIN_SIGMA combined error bars: 2.73, the
# two-sided 5 % point for eight comparisons at once (Bonferroni, 0.05 / 8 each).  With 2 each, one of eight observables
# of a faithful peer falls outside by chance in about 30 % of runs.
WITHIN_SIGMA = 2.73
FRAME_KEYS = ("oh_mean", "oh_sd", "angle_mean", "angle_sd", "T_O", "T_H")


def build_box(molecules):
    """A cubic box of TIP3P water with the given number of molecules, at water's density at 300 K."""
    forcefield = app.ForceField("tip3p.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(forcefield, model="tip3p", numAdded=molecules, neutralize=False)
    compress_to_volume(modeller, water_volume(modeller.topology))
    return forcefield, modeller


def make_system(forcefield, topology, rigid):
    system = forcefield.createSystem(topology, nonbondedMethod=app.PME, nonbondedCutoff=0.9 * unit.nanometer,
                                     rigidWater=rigid, constraints=None, removeCMMotion=False)
    return assign_force_groups(system, {mm.HarmonicBondForce: BOND_GROUP, mm.HarmonicAngleForce: ANGLE_GROUP})


def common_start(forcefield, modeller, start_ps, threads, minimizer_iterations=200, friction=FRICTION, seed=3):
    """The peers' common start: the box minimized, then start_ps of LangevinMiddle (flexible, 0.5 fs, at `friction`
    in 1/ps, random numbers from `seed`); its positions."""
    system = make_system(forcefield, modeller.topology, False)
    integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, friction, 0.5e-3)
    integrator.setRandomNumberSeed(seed)
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName("CPU"), {"Threads": str(threads)})
    context.setPositions(modeller.positions)
    mm.LocalEnergyMinimizer.minimize(context, 10.0, minimizer_iterations)
    context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, seed)
    integrator.step(int(round(start_ps * 2000)))
    return context.getState(getPositions=True).getPositions()


def langevin_peer(step_fs, dynamics=False):
    def factory(seed):
        integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, step_fs * 1e-3)
        integrator.setRandomNumberSeed(seed)
        return integrator
    return ("LangevinMiddle flexible %g fs" % step_fs, False, factory, dynamics)


def flavor_peer(averaging, delta, tau, angles, middle, dynamics=False):
    """(name, rigid, factory, dynamics) of a FlavorIntegrator (Verlet scheme) with the O-H bonds stiff, and the H-O-H
    angles too if `angles`; `middle`: the thermostat in the middle of the microstep."""
    averagings = {"Nonintrusive": openmmflavors.FlavorIntegrator.Nonintrusive,
                  "Artificial": openmmflavors.FlavorIntegrator.Artificial,
                  "ArtificialProjected": openmmflavors.FlavorIntegrator.ArtificialProjected}
    groups = {BOND_GROUP} | ({ANGLE_GROUP} if angles else set())

    def factory(seed):
        integrator = openmmflavors.FlavorIntegrator(delta * unit.femtosecond, tau * unit.femtosecond, groups)
        integrator.setAveraging(averagings[averaging])
        integrator.setTemperature(TEMPERATURE * unit.kelvin)
        integrator.setFriction(FRICTION / unit.picosecond)
        if middle:
            integrator.setThermostatPlacement(openmmflavors.FlavorIntegrator.Middle)
        integrator.setRandomNumberSeed(seed)
        return integrator

    name = "FLAVOR %s%s%s δ=%g fs τ=%g fs" % (averaging, " +angles" if angles else "", " Middle" if middle else "",
                                             delta, tau)
    return (name, False, factory, dynamics)


def practitioner_peers():
    """The default set: LangevinMiddle (flexible) at the steps a practitioner would try, and the artificial FLAVOR
    (bonds and angles frozen, Middle) at long mesosteps (4, 6, 7, 8, 10 fs), with the delta = 6 fs variations that
    locate a bias."""
    result = [langevin_peer(0.25, True), langevin_peer(1.0), langevin_peer(1.5), langevin_peer(2.0, True),
              langevin_peer(2.5)]
    for delta, dynamics in ((4.0, True), (6.0, True), (7.0, True), (8.0, True), (10.0, True)):
        result.append(flavor_peer("ArtificialProjected", delta, 0.5, True, True, dynamics))
    result += [flavor_peer("ArtificialProjected", 6.0, 0.25, True, True), flavor_peer("ArtificialProjected", 6.0, 1.0,
                                                                                      True, True),
               flavor_peer("ArtificialProjected", 6.0, 0.5, True, False)]
    return result


def earlier_peers():
    """The scene's earlier peers (available by --peers)."""
    def seeded(make):
        def factory(seed):
            integrator = make()
            integrator.setRandomNumberSeed(seed)
            return integrator
        return factory
    result = [
        langevin_peer(0.5),
        ("LangevinMiddle rigid 2 fs", True, seeded(lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 2e-3)),
         False),
        ("MTSLangevin 2 fs / 4", False,
         seeded(lambda: mm.MTSLangevinIntegrator(TEMPERATURE, FRICTION, 2e-3,
                                                 [(0, 1), (BOND_GROUP, 4), (ANGLE_GROUP, 4)])), False),
    ]
    # (averaging, delta, tau, H-O-H angles stiff too, thermostat in the middle of the microstep)
    for setting in [("Nonintrusive", 2.0, 0.5, False, False), ("Artificial", 2.0, 0.5, False, False),
                    ("ArtificialProjected", 2.0, 0.5, False, False), ("ArtificialProjected", 2.0, 0.25, False, False),
                    ("ArtificialProjected", 2.5, 0.5, False, False), ("ArtificialProjected", 2.0, 0.5, True, False),
                    ("ArtificialProjected", 4.0, 0.5, True, False), ("ArtificialProjected", 2.0, 0.5, True, True),
                    ("ArtificialProjected", 4.0, 0.5, True, True)]:
        result.append(flavor_peer(*setting))
    return result


def quick_peers():
    """The smoke run's peers: one of every kind (the reference, a practitioner's LangevinMiddle step, the nonintrusive
    FLAVOR, the projected one with either thermostat placement), the dynamics measured on three of them."""
    return [langevin_peer(0.25, True), langevin_peer(2.0, True), flavor_peer("Nonintrusive", 2.0, 0.5, False, False),
            flavor_peer("ArtificialProjected", 2.0, 0.5, True, False),
            flavor_peer("ArtificialProjected", 2.0, 0.5, True, True, True)]


def peers(flavor_settings):
    """(name, rigid, factory) for every peer of the earlier set with these FLAVOR settings (averaging, delta, tau,
    angles stiff too, Middle); factory() returns the integrator.  examples/demo uses it with run_peer()."""
    result = [
        ("LangevinMiddle flexible 0.25 fs", False, lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 0.25e-3)),
        ("LangevinMiddle flexible 0.5 fs", False, lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 0.5e-3)),
        ("LangevinMiddle rigid 2 fs", True, lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 2e-3)),
        ("MTSLangevin 2 fs / 4", False,
         lambda: mm.MTSLangevinIntegrator(TEMPERATURE, FRICTION, 2e-3, [(0, 1), (BOND_GROUP, 4), (ANGLE_GROUP, 4)])),
    ]
    for averaging, delta, tau, angles, middle in flavor_settings:
        name, rigid, seeded_factory, _ = flavor_peer(averaging, delta, tau, angles, middle)
        result.append((name, rigid, lambda seeded_factory=seeded_factory: seeded_factory(1234)))
    return result


def frame_observables(positions, velocities, box, oxygens, masses, rdf_edges):
    """Per-frame averages: O-H length mean and spread, H-O-H angle mean and spread (degrees), T of O and H, g_OO."""
    o = positions[oxygens]
    h1 = positions[oxygens + 1]
    h2 = positions[oxygens + 2]
    d1, d2 = h1 - o, h2 - o
    r1, r2 = np.linalg.norm(d1, axis=1), np.linalg.norm(d2, axis=1)
    oh = np.concatenate([r1, r2])
    angle = np.degrees(np.arccos(np.clip(np.sum(d1 * d2, axis=1) / (r1 * r2), -1, 1)))
    v2 = np.sum(velocities ** 2, axis=1) * masses
    hydrogens = np.concatenate([oxygens + 1, oxygens + 2])
    t_o = np.sum(v2[oxygens]) / (3 * len(oxygens) * KB)
    t_h = np.sum(v2[hydrogens]) / (3 * len(hydrogens) * KB)
    # g_OO with the minimum image in the cubic box.
    diff = o[:, None, :] - o[None, :, :]
    diff -= box * np.round(diff / box)
    dist = np.linalg.norm(diff, axis=2)[np.triu_indices(len(o), 1)]
    counts, _ = np.histogram(dist, bins=rdf_edges)
    shells = 4 / 3 * np.pi * (rdf_edges[1:] ** 3 - rdf_edges[:-1] ** 3)
    density = len(o) / box ** 3
    g = counts / (shells * density * len(o) / 2)
    return oh.mean(), oh.std(), angle.mean(), angle.std(), t_o, t_h, g


def bond_velocities(positions, velocities, oxygens):
    """d(r_OH)/dt of every O-H bond (nm/ps): the relative velocity along the bond."""
    o, vo = positions[oxygens], velocities[oxygens]
    result = []
    for k in (1, 2):
        d = positions[oxygens + k] - o
        result.append(np.sum((velocities[oxygens + k] - vo) * d, axis=1) / np.linalg.norm(d, axis=1))
    return np.concatenate(result)


def angular_velocities(positions, velocities, oxygens, masses):
    """Each molecule's angular velocity about its centre of mass (rad/ps, rows x, y, z): I^-1 L."""
    index = oxygens[:, None] + np.arange(3)[None, :]
    m = masses[index][:, :, None]
    r = positions[index] - np.sum(m * positions[index], axis=1, keepdims=True) / np.sum(m, axis=1, keepdims=True)
    v = velocities[index] - np.sum(m * velocities[index], axis=1, keepdims=True) / np.sum(m, axis=1, keepdims=True)
    angular_momentum = np.sum(m * np.cross(r, v), axis=1)
    inertia = np.sum(m[:, :, :, None] * (np.sum(r * r, axis=2)[:, :, None, None] * np.eye(3)
                                          - r[:, :, :, None] * r[:, :, None, :]), axis=1)
    return np.linalg.solve(inertia, angular_momentum[:, :, None])[:, :, 0]


def power_spectrum(series, dt_ps, max_wavenumber=5000.0):
    """Mean power spectrum of the columns of `series` (rows: samples dt_ps apart), Hann-windowed, normalized to unit
    area over wavenumber; (wavenumbers in 1/cm, spectrum in cm) up to max_wavenumber or the Nyquist limit."""
    x = np.asarray(series, dtype=float)
    x = x - x.mean(axis=0)
    x = x * np.hanning(len(x))[:, None]
    power = np.mean(np.abs(np.fft.rfft(x, axis=0)) ** 2, axis=1)
    wavenumber = np.fft.rfftfreq(len(x), dt_ps) / C_CM_PER_PS
    keep = wavenumber <= max_wavenumber
    wavenumber, power = wavenumber[keep], power[keep]
    area = np.sum(power) * (wavenumber[1] - wavenumber[0]) if len(power) > 1 else 1.0
    return wavenumber, power / area


def diffusion(unwrapped, dt_ps, fit_from, fit_to, groups=BLOCKS):
    """Self-diffusion coefficient (1e-5 cm^2/s) of the oxygens from their mean-squared displacement (all time origins),
    a straight-line fit of MSD(t) = 6 D t + c over fit_from <= t <= fit_to ps; its error: the standard error over
    `groups` groups of molecules.  Also the MSD curve (nm^2) and its lags (ps)."""
    frames = len(unwrapped)
    lags = np.arange(1, frames)
    msd_per_molecule = np.array([np.mean(np.sum((unwrapped[lag:] - unwrapped[:-lag]) ** 2, axis=2), axis=0)
                                 for lag in lags])  # (lags, molecules)
    t = lags * dt_ps
    fit = (t >= fit_from - 1e-9) & (t <= fit_to + 1e-9)

    def slope(msd):
        return np.polyfit(t[fit], msd[fit], 1)[0] / 6 * 1000  # nm^2/ps = 1e-2 cm^2/s = 1000 x 1e-5 cm^2/s

    msd = msd_per_molecule.mean(axis=1)
    per_group = [slope(msd_per_molecule[:, g::groups].mean(axis=1)) for g in range(groups)]
    return {"D": float(slope(msd)), "D_error": float(np.std(per_group, ddof=1) / math.sqrt(groups)),
            "msd_t": list(map(float, t)), "msd": list(map(float, msd)), "fit_ps": [fit_from, fit_to]}


def run_peer(name, rigid, factory, forcefield, topology, start_positions, equilibration_ps, production_ps, frames,
             threads):
    """One peer run on its own (not interleaved), as the earlier scene ran them: its record with block-average
    errors and ns/day over its production.  examples/demo uses it."""
    system = make_system(forcefield, topology, rigid)
    integrator = factory()
    platform = mm.Platform.getPlatformByName("CPU")
    context = mm.Context(system, integrator, platform, {"Threads": str(threads)})
    context.setPositions(start_positions)
    if rigid:
        context.applyConstraints(1e-6)
    context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, 7)
    step_fs = integrator.getStepSize().value_in_unit(unit.femtosecond)
    n_molecules = topology.getNumResidues()
    masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
    oxygens = np.arange(0, system.getNumParticles(), 3)
    box = context.getState().getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    rdf_edges = np.linspace(0.2, min(0.9, box / 2), 71)
    record = {"name": name, "step_fs": step_fs, "rigid": rigid, "stable": True}
    try:
        integrator.step(int(round(equilibration_ps * 1000 / step_fs)))
        production = ProductionFrames(context, integrator, int(round(production_ps * 1000 / step_fs)), frames)
        series = {key: [] for key in ("oh_mean", "oh_sd", "angle_mean", "angle_sd", "T_O", "T_H", "pe_per_molecule")}
        g_sum = np.zeros(len(rdf_edges) - 1)
        for frame in production:
            values = frame_observables(frame.positions, frame.velocities, box, oxygens, masses, rdf_edges)
            for key, value in zip(("oh_mean", "oh_sd", "angle_mean", "angle_sd", "T_O", "T_H"), values[:6]):
                series[key].append(value)
            series["pe_per_molecule"].append(frame.potential_energy / n_molecules)
            g_sum += values[6]
        record["ns_per_day"] = production.ns_per_day(step_fs)
        add_block_errors(record, series, 5 if len(series["oh_mean"]) >= 10 else 2)
        g = g_sum / len(series["oh_mean"])
        record["g_OO"] = {"r": list(0.5 * (rdf_edges[1:] + rdf_edges[:-1])), "g": list(g)}
        record["g_OO_peak"] = float(g.max())
        record["g_OO_peak_r"] = float(record["g_OO"]["r"][int(np.argmax(g))])
    except mm.OpenMMException as error:
        record["stable"] = False
        record["error"] = str(error)
    return record


class PeerRun:
    """One peer in one seed's run: its Context, its equilibration, then production advanced round by round (frames
    recorded between the timed integrator.step calls), then the dynamics segment."""

    def __init__(self, peer, forcefield, topology, start_positions, seed, threads, rdf_edges):
        self.name, self.rigid, factory, self.dynamics = peer
        system = make_system(forcefield, topology, self.rigid)
        self.integrator = factory(seed)
        self.context = mm.Context(system, self.integrator, mm.Platform.getPlatformByName("CPU"),
                                  {"Threads": str(threads)})
        self.context.setPositions(start_positions)
        if self.rigid:
            self.context.applyConstraints(1e-6)
        self.context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, seed)
        self.step_fs = self.integrator.getStepSize().value_in_unit(unit.femtosecond)
        self.n_molecules = topology.getNumResidues()
        self.masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton)
                                for i in range(system.getNumParticles())])
        self.oxygens = np.arange(0, system.getNumParticles(), 3)
        self.box = self.context.getState().getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
        self.rdf_edges = rdf_edges
        self.series = {key: [] for key in FRAME_KEYS + ("pe_per_molecule",)}
        self.g_frames, self.unwrapped = [], []
        self.elapsed, self.steps_done, self.round_ns_per_day = 0.0, 0, []
        self.error = None

    def steps_for(self, picoseconds):
        return max(1, int(round(picoseconds * 1000 / self.step_fs)))

    def state(self, energy=False):
        state = self.context.getState(getPositions=True, getVelocities=True, getEnergy=energy,
                                      enforcePeriodicBox=False)
        q = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
        v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
        pe = state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole) if energy else 0.0
        if not np.all(np.isfinite(q)) or not np.all(np.isfinite(v)) or not math.isfinite(pe):
            raise mm.OpenMMException("non-finite state")
        return q, v, pe

    def equilibrate(self, picoseconds):
        try:
            self.integrator.step(self.steps_for(picoseconds))
            self.state()
        except mm.OpenMMException as error:
            self.error = "equilibration: %s" % error

    def production_round(self, frames, frame_steps):
        """frames frames, each after frame_steps timed steps."""
        if self.error:
            return
        elapsed = 0.0
        try:
            for _ in range(frames):
                begin = time.perf_counter()
                self.integrator.step(frame_steps)
                elapsed += time.perf_counter() - begin
                self.steps_done += frame_steps
                q, v, pe = self.state(energy=True)
                values = frame_observables(q, v, self.box, self.oxygens, self.masses, self.rdf_edges)
                for key, value in zip(FRAME_KEYS, values[:6]):
                    self.series[key].append(value)
                self.series["pe_per_molecule"].append(pe / self.n_molecules)
                self.g_frames.append(values[6])
                o = q[self.oxygens]
                if self.unwrapped:
                    jump = o - self.previous_o
                    self.unwrapped.append(self.unwrapped[-1] + jump - self.box * np.round(jump / self.box))
                else:
                    self.unwrapped.append(o.copy())
                self.previous_o = o
        except mm.OpenMMException as error:
            self.error = "production after %.3f ps: %s" % (self.steps_done * self.step_fs * 1e-3, error)
        self.elapsed += elapsed
        if elapsed > 0:
            self.round_ns_per_day.append(frames * frame_steps * self.step_fs * 1e-6 / elapsed * 86400)

    def spectra(self, picoseconds, sample_fs):
        """Frames every sample_fs (every step for longer steps): power spectra of the O-H bond-length velocity, of
        the hydrogens' velocities and of the molecules' angular velocities (the librations)."""
        every = max(1, int(round(sample_fs / self.step_fs)))
        samples = max(8, int(round(picoseconds * 1000 / (every * self.step_fs))))
        bond_v, hydrogen_v, rotation = [], [], []
        hydrogens = np.concatenate([self.oxygens + 1, self.oxygens + 2])
        try:
            for _ in range(samples):
                self.integrator.step(every)
                q, v, _ = self.state()
                bond_v.append(bond_velocities(q, v, self.oxygens))
                hydrogen_v.append(v[hydrogens].ravel())
                rotation.append(angular_velocities(q, v, self.oxygens, self.masses).ravel())
        except mm.OpenMMException as error:
            return {"error": str(error)}
        dt_ps = every * self.step_fs * 1e-3
        k, stretch = power_spectrum(bond_v, dt_ps)
        k_h, vdos = power_spectrum(hydrogen_v, dt_ps)
        _, libration = power_spectrum(rotation, dt_ps)
        return {"sample_fs": every * self.step_fs, "samples": samples, "wavenumber": list(map(float, k)),
                "oh_bond_velocity": list(map(float, stretch)), "wavenumber_h": list(map(float, k_h)),
                "hydrogen_velocity": list(map(float, vdos)), "angular_velocity": list(map(float, libration))}

    def record(self, production_ps):
        record = {"name": self.name, "step_fs": self.step_fs, "rigid": self.rigid, "stable": self.error is None}
        if self.error:
            record["error"] = self.error
            return record
        record["ns_per_day"] = self.steps_done * self.step_fs * 1e-6 / self.elapsed * 86400
        record["round_ns_per_day"] = self.round_ns_per_day
        blocks = BLOCKS if len(self.g_frames) >= 2 * BLOCKS else 2
        for key, values in self.series.items():
            record[key], record[key + "_error"] = block_error(values, blocks)
        g = np.mean(self.g_frames, axis=0)
        r = 0.5 * (self.rdf_edges[1:] + self.rdf_edges[:-1])
        record["g_OO"] = {"r": list(map(float, r)), "g": list(map(float, g))}
        usable = len(self.g_frames) // blocks * blocks
        block_peaks = np.max(np.mean(np.reshape(self.g_frames[:usable], (blocks, -1, len(r))), axis=1), axis=1)
        record["g_OO_peak"] = float(g.max())
        record["g_OO_peak_error"] = float(np.std(block_peaks, ddof=1) / math.sqrt(blocks))
        record["g_OO_peak_r"] = float(r[int(np.argmax(g))])
        if self.dynamics:
            # Frames are frame_steps apart: production_ps / frames to within one step.
            dt_ps = self.step_fs * 1e-3 * self.steps_done / len(self.unwrapped)
            record["diffusion"] = diffusion(np.array(self.unwrapped), dt_ps, 0.1 * production_ps,
                                            0.5 * production_ps)
        return record


def run_seed(selected, forcefield, modeller, seed, args):
    """Every selected peer from one start (seeded by `seed`); their records."""
    begin = time.time()
    start = common_start(forcefield, modeller, args.start, args.threads, 20 if args.quick else 200, seed=seed)
    print("seed %d: common start done (%.0f s)" % (seed, time.time() - begin), flush=True)
    box = modeller.topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    rdf_edges = np.linspace(0.2, min(0.9, box / 2), 71)
    runs = []
    for index, peer in enumerate(selected):
        run = PeerRun(peer, forcefield, modeller.topology, start, seed * 1000 + index + 1, args.threads, rdf_edges)
        run.equilibrate(args.equilibration)
        runs.append(run)
    print("seed %d: %d peers equilibrated (%.0f s)" % (seed, len(runs), time.time() - begin), flush=True)
    frames_per_round = max(1, int(round(args.production / args.frame_ps / args.rounds)))
    for round_ in range(args.rounds):
        order = runs if round_ % 2 == 0 else runs[::-1]
        for run in order:
            run.production_round(frames_per_round, run.steps_for(args.frame_ps))
        print("seed %d: round %d/%d (%.0f s)" % (seed, round_ + 1, args.rounds, time.time() - begin), flush=True)
    records = []
    for run in runs:
        record = run.record(args.production)
        if run.dynamics and record["stable"]:
            record["spectra"] = run.spectra(args.spectrum, args.sample_fs)
        records.append(record)
        print(summary_line(record), flush=True)
    print("seed %d: done (%.0f s)" % (seed, time.time() - begin), flush=True)
    return records


def interleaved_timing(selected, forcefield, modeller, args):
    """Speed only: every selected peer's Context from one start (seed args.seeds[0]), --equilibration ps each, then
    --timing-rounds rounds in which each peer in turn steps --timing-ps ps (no frames; the order reversed every other
    round).  Per peer: ns/day over all rounds, each round's ns/day, and the median over rounds of its per-round ratio
    to LangevinMiddle 2 fs; also the process's CPU seconds per simulated ps (all threads) and their ratio to
    LangevinMiddle 2 fs's, which the machine's load changes less."""
    seed = args.seeds[0]
    start = common_start(forcefield, modeller, args.start, args.threads, 20 if args.quick else 200, seed=seed)
    box = modeller.topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    runs = []
    for index, peer in enumerate(selected):
        run = PeerRun(peer, forcefield, modeller.topology, start, seed * 1000 + index + 1, args.threads,
                      np.linspace(0.2, min(0.9, box / 2), 71))
        run.equilibrate(args.equilibration)
        runs.append(run)
    rounds = {run.name: [] for run in runs}
    elapsed = {run.name: 0.0 for run in runs}
    # CPU seconds of this process (all its threads) while stepping: the work, whatever the machine's load.
    cpu = {run.name: 0.0 for run in runs}
    for round_ in range(args.timing_rounds):
        for run in (runs if round_ % 2 == 0 else runs[::-1]):
            if run.error:
                continue
            steps = run.steps_for(args.timing_ps)
            begin, begin_cpu = time.perf_counter(), time.process_time()
            run.integrator.step(steps)
            seconds = time.perf_counter() - begin
            cpu[run.name] += time.process_time() - begin_cpu
            elapsed[run.name] += seconds
            rounds[run.name].append(steps * run.step_fs * 1e-6 / seconds * 86400)
        print("timing round %d/%d" % (round_ + 1, args.timing_rounds), flush=True)
    lm2 = rounds.get("LangevinMiddle flexible 2 fs")
    result = []
    for run in runs:
        entry = {"name": run.name, "step_fs": run.step_fs, "round_ns_per_day": rounds[run.name]}
        try:
            run.state()
        except mm.OpenMMException as error:
            run.error = str(error)
        if run.error or not rounds[run.name]:
            entry["error"] = run.error
        else:
            simulated_ns = len(rounds[run.name]) * run.steps_for(args.timing_ps) * run.step_fs * 1e-6
            entry["ns_per_day"] = simulated_ns / elapsed[run.name] * 86400
            entry["cpu_s_per_ps"] = cpu[run.name] / (simulated_ns * 1000)
            if lm2 and len(lm2) == len(rounds[run.name]):
                entry["vs_langevin_2fs_median_round"] = float(np.median(np.array(rounds[run.name]) / np.array(lm2)))
        result.append(entry)
        print("%-52s %s" % (run.name, "failed: %s" % entry["error"] if "error" in entry else
                            "%.1f ns/day, x %.2f LangevinMiddle 2 fs (median over rounds)" % (
                                entry["ns_per_day"], entry.get("vs_langevin_2fs_median_round", float("nan")))))
    lm2_entry = next((e for e in result if e["name"] == "LangevinMiddle flexible 2 fs" and "ns_per_day" in e), None)
    for entry in result:
        if lm2_entry and "ns_per_day" in entry:
            entry["vs_langevin_2fs"] = entry["ns_per_day"] / lm2_entry["ns_per_day"]
            entry["cpu_vs_langevin_2fs"] = lm2_entry["cpu_s_per_ps"] / entry["cpu_s_per_ps"]
            print("%-52s CPU %.2f s per ps: x %.2f LangevinMiddle 2 fs in CPU time" % (
                entry["name"], entry["cpu_s_per_ps"], entry["cpu_vs_langevin_2fs"]))
    return result


def summary_line(record):
    if not record["stable"]:
        return "%-52s UNSTABLE (%s)" % (record["name"], record["error"])
    return ("%-52s O-H %.5f sd %.5f  HOH %.2f sd %.3f  PE %.2f±%.2f  T_O %.0f  T_H %.0f  g %.2f  %.1f ns/day" % (
        record["name"], record["oh_mean"], record["oh_sd"], record["angle_mean"], record["angle_sd"],
        record["pe_per_molecule"], record["pe_per_molecule_error"], record["T_O"], record["T_H"],
        record["g_OO_peak"], record["ns_per_day"]))


def combine(seeds):
    """Per peer over the seeds: the mean of each observable and its error bar, the larger of the block error of that
    mean (sqrt(sum of squares)/n) and the run-to-run standard error (standard deviation over the seeds / sqrt(n));
    also each seed's values.  Diffusion alike (error bars of molecule groups)."""
    names = [r["name"] for r in seeds[0]["peers"]]
    summary = []
    for name in names:
        runs = [next(r for r in seed["peers"] if r["name"] == name) for seed in seeds]
        stable = [r for r in runs if r["stable"]]
        entry = {"name": name, "step_fs": runs[0]["step_fs"], "runs": len(runs), "stable_runs": len(stable)}
        if len(stable) < len(runs):
            entry["errors"] = [r.get("error") for r in runs if not r["stable"]]
        if not stable:
            summary.append(entry)
            continue
        n = len(stable)
        for key in CHECKED + ("ns_per_day",):
            values = np.array([r[key] for r in stable])
            entry[key] = float(values.mean())
            entry[key + "_runs"] = list(map(float, values))
            if key == "ns_per_day":
                continue
            block = math.sqrt(sum(r[key + "_error"] ** 2 for r in stable)) / n
            spread = float(np.std(values, ddof=1)) if n > 1 else float("nan")
            entry[key + "_run_sd"] = spread
            entry[key + "_error"] = max(block, spread / math.sqrt(n)) if n > 1 else block
        entry["round_ns_per_day"] = [r["round_ns_per_day"] for r in stable]
        entry["g_OO"] = {"r": stable[0]["g_OO"]["r"], "g": list(np.mean([r["g_OO"]["g"] for r in stable], axis=0))}
        if "diffusion" in stable[0]:
            values = np.array([r["diffusion"]["D"] for r in stable])
            block = math.sqrt(sum(r["diffusion"]["D_error"] ** 2 for r in stable)) / n
            entry["D"] = float(values.mean())
            entry["D_runs"] = list(map(float, values))
            entry["D_error"] = max(block, float(np.std(values, ddof=1)) / math.sqrt(n)) if n > 1 else block
            entry["msd_t"] = stable[0]["diffusion"]["msd_t"]
            entry["msd"] = list(np.mean([r["diffusion"]["msd"] for r in stable], axis=0))
        spectra = [r["spectra"] for r in stable if "spectra" in r and "error" not in r["spectra"]]
        if spectra:
            entry["spectra"] = {key: spectra[0][key] for key in ("sample_fs", "wavenumber", "wavenumber_h")}
            for key in ("oh_bond_velocity", "hydrogen_velocity", "angular_velocity"):
                if all(key in s for s in spectra):
                    entry["spectra"][key] = list(np.mean([s[key] for s in spectra], axis=0))
            k, s = np.array(entry["spectra"]["wavenumber"]), np.array(entry["spectra"]["oh_bond_velocity"])
            entry["stretch_peak_cm"] = float(k[int(np.argmax(s))])
            if "angular_velocity" in entry["spectra"]:
                libration = np.array(entry["spectra"]["angular_velocity"])
                entry["libration_peak_cm"] = float(k[int(np.argmax(libration))])
                entry["libration_mean_cm"] = float(np.sum(k * libration) / np.sum(libration))
        summary.append(entry)
    return summary


def compare(summary):
    """For each peer, the distance of each observable from the reference (the first peer) in units of the combined
    error bar, whether all are within WITHIN_SIGMA of them, and the speed ratios: to the fastest LangevinMiddle (flexible) that
    stays within the reference's error bars on every observable (the practitioner's choice), and to LangevinMiddle
    at 2 fs."""
    reference = summary[0]
    for entry in summary:
        if "oh_mean" not in entry or "oh_mean" not in reference:
            continue
        entry["sigma"] = {}
        for key in CHECKED:
            combined = math.hypot(entry[key + "_error"], reference[key + "_error"])
            entry["sigma"][key] = abs(entry[key] - reference[key]) / combined if combined > 0 else 0.0
        entry["within"] = entry is reference or all(s <= WITHIN_SIGMA for s in entry["sigma"].values())
    faithful = [e for e in summary if e["name"].startswith("LangevinMiddle flexible") and e.get("within")
                and e["stable_runs"] == e["runs"]]
    baseline = max(faithful, key=lambda e: e["ns_per_day"]) if faithful else None
    lm2 = next((e for e in summary if e["name"] == "LangevinMiddle flexible 2 fs" and "ns_per_day" in e), None)
    def median_ratio(entry, peer):
        """The median over seeds and rounds of entry's ns/day over peer's in the same round (both stable)."""
        ratios = [a / b for runs_a, runs_b in zip(entry["round_ns_per_day"], peer["round_ns_per_day"])
                  for a, b in zip(runs_a, runs_b)]
        return float(np.median(ratios)) if ratios and entry["runs"] == peer["runs"] else float("nan")

    for entry in summary:
        if "ns_per_day" in entry:
            if baseline:
                entry["speed_vs_faithful_langevin"] = entry["ns_per_day"] / baseline["ns_per_day"]
                entry["speed_vs_faithful_langevin_median_round"] = median_ratio(entry, baseline)
            if lm2:
                entry["speed_vs_langevin_2fs"] = entry["ns_per_day"] / lm2["ns_per_day"]
                entry["speed_vs_langevin_2fs_median_round"] = median_ratio(entry, lm2)
    return baseline["name"] if baseline else None


def print_summary(summary, baseline):
    print("\nover %d seed(s); error bars: block and run-to-run, whichever is larger; σ against %s" % (
        summary[0]["runs"], summary[0]["name"]))
    print("fastest LangevinMiddle within %gσ of the reference on every observable: %s" % (WITHIN_SIGMA, baseline))
    for e in summary:
        if "oh_mean" not in e:
            print("%-52s UNSTABLE in every run" % e["name"])
            continue
        print("%-52s O-H %.5f±%.5f sd %.6f±%.6f HOH %.2f±%.2f sd %.3f±%.3f PE %.2f±%.2f T_O %.1f±%.1f "
              "T_H %.1f±%.1f g %.2f±%.2f %.1f ns/day x%.2f (x%.2f LM 2 fs)%s %s" % (
                  e["name"], e["oh_mean"], e["oh_mean_error"], e["oh_sd"], e["oh_sd_error"], e["angle_mean"],
                  e["angle_mean_error"], e["angle_sd"], e["angle_sd_error"], e["pe_per_molecule"],
                  e["pe_per_molecule_error"], e["T_O"], e["T_O_error"], e["T_H"], e["T_H_error"], e["g_OO_peak"],
                  e["g_OO_peak_error"], e["ns_per_day"], e.get("speed_vs_faithful_langevin", float("nan")),
                  e.get("speed_vs_langevin_2fs", float("nan")),
                  (" D %.2f±%.2f" % (e["D"], e["D_error"])) if "D" in e else "",
                  "within" if e.get("within") else "OUT " + ", ".join(
                      "%s %.1fσ" % (k, s) for k, s in e.get("sigma", {}).items() if s > WITHIN_SIGMA)))
        if "stretch_peak_cm" in e:
            print("%52s O-H stretch peak %.0f cm-1, libration peak %.0f cm-1 (spectrum sampled every %g fs)" % (
                "", e["stretch_peak_cm"], e.get("libration_peak_cm", float("nan")), e["spectra"]["sample_fs"]))


def markdown_tables(data):
    """The run's tables in Markdown (the scene's README quotes them): observables and speed, each seed's values, and
    the dynamics."""
    summary, baseline = data["summary"], data.get("faithful_langevin")
    reference = summary[0]

    def ratio(entry, key):
        return "%.2f (%.2f)" % (entry.get(key, float("nan")), entry.get(key + "_median_round", float("nan")))

    # One speed column when the baseline is LangevinMiddle 2 fs itself.
    both = baseline != "LangevinMiddle flexible 2 fs"
    lines = ["| peer | O–H mean (nm) | O–H sd (nm) | H–O–H (°) | H–O–H sd (°) | PE/molecule (kJ/mol) | T_O (K) "
             "| T_H (K) | g_OO peak | ns/day | × %s (median over rounds) |%s largest σ |"
             % (short_name(baseline) if baseline else "—", " × LM 2 fs (median over rounds) |" if both else ""),
             "|---|---|---|---|---|---|---|---|---|---|---|---|" + ("---|" if both else "")]
    for e in summary:
        if "oh_mean" not in e:
            lines.append("| %s | unstable in %d of %d runs |" % (e["name"], e["runs"] - e["stable_runs"], e["runs"]))
            continue
        worst = max(e["sigma"].items(), key=lambda item: item[1]) if e is not reference else None
        lines.append("| %s%s | %.6f ± %.6f | %.6f ± %.6f | %.2f ± %.2f | %.3f ± %.3f | %.2f ± %.2f | %.1f ± %.1f | "
                     "%.1f ± %.1f | %.2f ± %.2f | %.1f | %s |%s %s |" % (
                         e["name"], "" if e["stable_runs"] == e["runs"] else " (%d of %d runs stable)" % (
                             e["stable_runs"], e["runs"]),
                         e["oh_mean"], e["oh_mean_error"], e["oh_sd"], e["oh_sd_error"], e["angle_mean"],
                         e["angle_mean_error"], e["angle_sd"], e["angle_sd_error"], e["pe_per_molecule"],
                         e["pe_per_molecule_error"], e["T_O"], e["T_O_error"], e["T_H"], e["T_H_error"],
                         e["g_OO_peak"], e["g_OO_peak_error"], e["ns_per_day"],
                         ratio(e, "speed_vs_faithful_langevin"),
                         " %s |" % ratio(e, "speed_vs_langevin_2fs") if both else "",
                         "—" if worst is None else "%.1f (%s)%s" % (worst[1], worst[0],
                                                                    "" if e.get("within") else " **out**")))
    lines += ["", "| peer | O–H mean per seed (nm) | PE/molecule per seed (kJ/mol) | O–H sd per seed (nm) | "
              "H–O–H sd per seed (°) | T_H per seed (K) | ns/day per seed |", "|---|---|---|---|---|---|---|"]
    for e in summary:
        if "oh_mean" in e:
            lines.append("| %s | %s | %s | %s | %s | %s | %s |" % (
                e["name"], ", ".join("%.6f" % v for v in e["oh_mean_runs"]),
                ", ".join("%.2f" % v for v in e["pe_per_molecule_runs"]),
                ", ".join("%.6f" % v for v in e["oh_sd_runs"]), ", ".join("%.3f" % v for v in e["angle_sd_runs"]),
                ", ".join("%.1f" % v for v in e["T_H_runs"]), ", ".join("%.1f" % v for v in e["ns_per_day_runs"])))
    lines += ["", "| peer | D (10⁻⁵ cm²/s) | D per seed | O–H band peak, simulated time (cm⁻¹) | × δ/τ (cm⁻¹) | "
              "libration peak / mean (cm⁻¹) | spectrum sampled every (fs) |", "|---|---|---|---|---|---|---|"]
    # Below 5 ps of production the MSD is not yet diffusive: no D (as in the chart).
    measured = data["production_ps"] >= 5
    for e in summary:
        if "D" in e:
            delta, tau = flavor_steps(e["name"])
            peak = e.get("stretch_peak_cm", float("nan"))
            lines.append("| %s | %s | %s | %.0f | %s | %s | %s |" % (
                e["name"], "%.2f ± %.2f" % (e["D"], e["D_error"]) if measured else "—",
                ", ".join("%.2f" % v for v in e["D_runs"]) if measured else "—", peak,
                "%.0f" % (peak * delta / tau) if delta else "—",
                "%.0f / %.0f" % (e["libration_peak_cm"], e["libration_mean_cm"]) if "libration_mean_cm" in e else "—",
                "%g" % e["spectra"]["sample_fs"] if "spectra" in e else "—"))
    return "\n".join(lines)


def short_name(name):
    """A peer's name in the charts' notation."""
    return (name.replace("LangevinMiddle flexible", "LangevinMiddle").replace("FLAVOR ArtificialProjected", "FLAVOR AP")
            .replace(" τ=", ", τ = ").replace("δ=", "δ = "))


def plot(data, path):
    plt = reporting.pyplot()
    from matplotlib.ticker import MaxNLocator
    summary = [e for e in data["summary"] if "oh_mean" in e]
    unstable = [e["name"] for e in data["summary"] if "oh_mean" not in e]
    reference = data["summary"][0]
    panels = [("oh_mean", "mean O–H length (nm)"), ("oh_sd", "O–H spread, standard deviation (nm)"),
              ("angle_mean", "mean H–O–H angle (°)"), ("angle_sd", "H–O–H spread, standard deviation (°)"),
              ("pe_per_molecule", "potential energy per molecule (kJ/mol)"), ("T_O", "kinetic T of O (K)"),
              ("T_H", "kinetic T of H (K)"), ("g_OO_peak", "g_OO first-peak height"),
              ("ns_per_day", "speed (ns/day, CPU platform, 2 threads)")]
    fig, axes = plt.subplots(2, 5, figsize=(26, 11))
    axes = axes.ravel()
    labels = [short_name(e["name"]) + ("" if e.get("within") else "  (out)") for e in summary]
    y = np.arange(len(summary))
    colors = ["tab:green" if e.get("within") else "tab:red" for e in summary]
    for ax, (key, label) in zip(axes, panels):
        for yi, e, c in zip(y, summary, colors):
            ax.errorbar(e[key], yi, xerr=e.get(key + "_error", 0.0), fmt="o", capsize=3, color=c)
            for value in e.get(key + "_runs", []) if key != "ns_per_day" else []:
                ax.plot(value, yi, "x", color="gray", ms=5)
        if key != "ns_per_day" and "oh_mean" in reference:
            ax.axvspan(reference[key] - 2 * reference[key + "_error"], reference[key] + 2 * reference[key + "_error"],
                       color="gray", alpha=0.2, lw=0)
            ax.axvline(reference[key], color="gray", ls="--", lw=1)
        ax.set_yticks(y)
        ax.set_yticklabels(labels if ax in (axes[0], axes[5]) else [], fontsize=8)
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.ticklabel_format(axis="x", useOffset=False, style="plain")
        ax.set_xlabel(label)
        ax.invert_yaxis()
    for yi, e in zip(y, summary):
        if "speed_vs_langevin_2fs" in e:
            axes[8].annotate("%.2f×" % e["speed_vs_langevin_2fs"], (e["ns_per_day"], yi), xytext=(6, 3),
                             textcoords="offset points", fontsize=8)
    axes[8].set_xlabel("speed (ns/day, CPU platform, 2 threads; labels: × LangevinMiddle 2 fs)")
    ax = axes[9]
    for i, e in enumerate(summary):
        ax.plot(e["g_OO"]["r"], e["g_OO"]["g"], label=short_name(e["name"]), lw=1, color=plt.get_cmap("tab20")(i % 20))
    ax.set_xlabel("r (nm)")
    ax.set_ylabel("g_OO(r)")
    ax.legend(fontsize=6)
    fig.text(0.01, 0.005, textwrap.fill("Points: mean over %d seed(s) with error bars (the larger of block and run-to-run); gray "
             "crosses: each seed's value; dashed line and band: the reference (%s) ± 2 of its error bars.  Green: every "
             "observable within 2.73 combined error bars of the reference (two-sided 5 %% over the 8 observables); "
             "red: not.  FLAVOR AP: ArtificialProjected; "
             "+angles: the H–O–H angles stiff (frozen) with the O–H bonds; Middle: the thermostat in the microstep.  "
             % (
                 reference["runs"], short_name(reference["name"])) +
             ("Unstable (blew up): " + ", ".join(unstable) if unstable else "Every peer stayed stable."), 230),
             fontsize=9)
    steps = [e["step_fs"] for e in data["summary"] if e["name"].startswith("LangevinMiddle flexible")]
    others = [e for e in data["summary"] if not e["name"].startswith(("LangevinMiddle flexible", "FLAVOR"))]
    fig.suptitle("Flexible TIP3P water (%s atoms, PME, 300 K, friction 1/ps): FLAVORs (mesostep δ, microstep τ) "
                 "against LangevinMiddle (flexible) at %s fs%s, mean over %d seed(s)" % (
                     format(data["atoms"], ","), ", ".join("%g" % h for h in steps),
                     " and other OpenMM integrators" if others else "", reference["runs"]))
    fig.tight_layout(rect=(0, 0.035, 1, 0.98))
    reporting.save_figure(fig, path, dpi=80)


def plot_dynamics(data, path):
    plt = reporting.pyplot()
    dynamics = [e for e in data["summary"] if "D" in e]
    reference = data["summary"][0]
    fig, axes = plt.subplots(2, 2, figsize=(16, 11))
    cmap = plt.get_cmap("tab10")
    ax = axes[0, 0]
    # Below 5 ps of production the fit range (10-50 % of it) is not yet the diffusive regime: no D is shown.
    measured = data["production_ps"] >= 5
    for i, e in enumerate(dynamics):
        ax.plot(e["msd_t"], e["msd"], color=cmap(i), label="%s: D = %.2f ± %.2f" % (
            short_name(e["name"]), e["D"], e["D_error"]) if measured else short_name(e["name"]))
    if measured:
        ax.axvspan(*data["msd_fit_ps"], color="gray", alpha=0.15, lw=0, label="fit range")
        ax.set_title("Oxygens' mean-squared displacement (unwrapped); D in 10⁻⁵ cm²/s")
    else:
        ax.set_title("Oxygens' MSD over %g ps of production: too short for a diffusion coefficient"
                     % data["production_ps"])
    ax.set_xlabel("lag t (ps)")
    ax.set_ylabel("oxygen MSD (nm²)")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    for i, e in enumerate(dynamics):
        if "spectra" in e:
            s = e["spectra"]
            ax.plot(s["wavenumber"], s["oh_bond_velocity"], color=cmap(i),
                    label="%s (sampled every %g fs), peak %.0f cm⁻¹" % (short_name(e["name"]), s["sample_fs"],
                                                                        e["stretch_peak_cm"]))
    ax.set_xlabel("wavenumber in simulated time (cm⁻¹)")
    ax.set_ylabel("power of d(r_OH)/dt, unit area (cm)")
    ax.set_title("O–H bond-length velocity spectrum: a FLAVOR's bonds move only during τ of each δ")
    ax.legend(fontsize=7)
    ax = axes[1, 0]
    for i, e in enumerate(dynamics):
        if "spectra" not in e:
            continue
        s = e["spectra"]
        delta, tau = flavor_steps(e["name"])
        factor = delta / tau if delta else 1.0
        k = np.array(s["wavenumber"]) * factor
        ax.plot(k, np.array(s["oh_bond_velocity"]) / factor, color=cmap(i),
                label=short_name(e["name"]) + (" (wavenumber × δ/τ = %g)" % factor if delta else ""))
    ax.set_xlim(2500, 5000)
    ax.set_xlabel("wavenumber in the stiff coordinates' own time (cm⁻¹): simulated time × δ/τ for a FLAVOR")
    ax.set_ylabel("power of d(r_OH)/dt, unit area (cm)")
    ax.set_title("The same spectra on the stiff clock (the time the bonds move; a FLAVOR's resolution δ/τ× coarser)",
                 fontsize=10)
    ax.legend(fontsize=7)
    ax = axes[1, 1]
    rotation = all("angular_velocity" in e["spectra"] for e in dynamics if "spectra" in e)
    for i, e in enumerate(dynamics):
        if "spectra" in e:
            s = e["spectra"]
            if rotation:
                ax.plot(s["wavenumber"], s["angular_velocity"], color=cmap(i),
                        label="%s, peak %.0f, mean %.0f cm⁻¹" % (short_name(e["name"]), e["libration_peak_cm"],
                                                                 e["libration_mean_cm"]))
            else:
                ax.plot(s["wavenumber_h"], s["hydrogen_velocity"], color=cmap(i), label=short_name(e["name"]))
    ax.set_xlim(0, 2000)
    ax.set_xlabel("wavenumber in simulated time (cm⁻¹)")
    if rotation:
        ax.set_ylabel("power of the molecules' angular velocity, unit area (cm)")
        ax.set_title("Angular velocity spectrum: the librations (soft, integrated with step δ)")
    else:
        ax.set_ylabel("power of the hydrogens' velocity, unit area (cm)")
        ax.set_title("Hydrogen velocity spectrum: librations and, for a FLAVOR, its slowed O–H band")
    ax.legend(fontsize=7)
    fig.suptitle("Flexible TIP3P water, dynamics: LangevinMiddle (%s: the reference) against the artificial FLAVOR "
                 "(bonds and angles frozen, Middle), mean over %d seed(s)" % (short_name(reference["name"]),
                                                                           reference["runs"]))
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    reporting.save_figure(fig, path, dpi=80)


def flavor_steps(name):
    """(delta, tau) in fs of a FLAVOR peer's name; (None, None) for the others."""
    if not name.startswith("FLAVOR"):
        return None, None
    parts = name.replace("δ=", " δ= ").replace("τ=", " τ= ").split()
    return float(parts[parts.index("δ=") + 1]), float(parts[parts.index("τ=") + 1])


def plot_all(data, out):
    plot(data, os.path.join(out, "flexible_water.png"))
    plot_dynamics(data, os.path.join(out, "flexible_water_dynamics.png"))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a few femtoseconds per peer (smoke test)")
    parser.add_argument("--out", default="results/flexible_water")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--equilibration", type=float, default=1.0, help="ps per peer before measuring")
    parser.add_argument("--production", type=float, default=10.0, help="ps per peer")
    parser.add_argument("--start", type=float, default=10.0,
                        help="ps of common equilibration before the peers (default 10: at water's density 3 ps left "
                             "the reference 3 K cold)")
    parser.add_argument("--rounds", type=int, default=10, help="interleaved rounds of the production (default 10)")
    parser.add_argument("--frame-ps", type=float, default=0.1, help="ps between production frames (default 0.1)")
    parser.add_argument("--spectrum", type=float, default=2.0,
                        help="ps of the segment saved for the spectra, after the production (default 2)")
    parser.add_argument("--sample-fs", type=float, default=2.0, help="fs between the spectra's frames (default 2)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2],
                        help="one run per seed, each from its own start (default: 1 2)")
    parser.add_argument("--timing-rounds", type=int, metavar="N",
                        help="measure speed only: N interleaved rounds of --timing-ps ps per peer, no observables "
                             "(writes DIR/flexible_water_timing.json)")
    parser.add_argument("--timing-ps", type=float, default=0.2, help="ps per peer and timing round (default 0.2)")
    parser.add_argument("--molecules", type=int, default=501)
    parser.add_argument("--replot", metavar="JSON", help="only redraw the charts of an earlier run's JSON into --out")
    parser.add_argument("--set", choices=("practitioner", "earlier", "all"), default="practitioner",
                        help="the peers: the practitioner set (default), the scene's earlier set (the reference, "
                             "LangevinMiddle 0.5 fs, rigid water, MTSLangevin, every FLAVOR averaging at 2-4 fs) or "
                             "both")
    parser.add_argument("--peers", nargs="+", metavar="NAME",
                        help="run only the peers of --set whose names contain one of these strings")
    args = parser.parse_args()
    reporting.set_smoke_run(args.quick)
    if args.replot:
        # The summary is recomputed from the seeds' records (the same code as at the end of a run).
        def replot(data, path):
            data["summary"] = combine(data["seeds"])
            data["faithful_langevin"] = compare(data["summary"])
            plot_all(data, args.out)
            print(markdown_tables(data))
        reporting.replot(args.replot, args.out, "flexible_water", replot)
        return
    if args.quick:
        args.equilibration, args.production, args.start, args.rounds = 0.005, 0.02, 0.1, 2
        args.frame_ps, args.spectrum, args.seeds = 0.002, 0.02, args.seeds[:1]
    if args.quick:
        pool = quick_peers()
    else:
        earlier = [langevin_peer(0.25, True)] + earlier_peers()
        practitioner = practitioner_peers()
        both = practitioner + [peer for peer in earlier if peer[0] not in {p[0] for p in practitioner}]
        pool = {"practitioner": practitioner, "earlier": earlier, "all": both}[args.set]
    selected = [peer for peer in pool if args.peers is None or any(part in peer[0] for part in args.peers)]
    if not selected:
        parser.error("--peers %s matches none of the peers" % " ".join(args.peers))
    forcefield, modeller = build_box(args.molecules)
    os.makedirs(args.out, exist_ok=True)
    begin = time.time()
    if args.timing_rounds:
        timing = interleaved_timing(selected, forcefield, modeller, args)
        reporting.write_json(os.path.join(args.out, "flexible_water_timing.json"), {
            "threads": args.threads, "rounds": args.timing_rounds, "ps_per_round": args.timing_ps,
            "equilibration_ps": args.equilibration, "seed": args.seeds[0], "peers": timing,
            "wall_s": time.time() - begin})
        return
    data = {"atoms": 3 * args.molecules, "temperature_K": TEMPERATURE, "friction_per_ps": FRICTION,
            "start_equilibration_ps": args.start, "equilibration_ps": args.equilibration,
            "production_ps": args.production, "rounds": args.rounds, "frame_ps": args.frame_ps,
            "spectrum_ps": args.spectrum, "sample_fs": args.sample_fs, "threads": args.threads, "quick": args.quick,
            "msd_fit_ps": [0.1 * args.production, 0.5 * args.production], "seeds": []}
    for seed in args.seeds:
        data["seeds"].append({"seed": seed, "peers": run_seed(selected, forcefield, modeller, seed, args)})
        data["summary"] = combine(data["seeds"])
        data["faithful_langevin"] = compare(data["summary"])
        data["wall_s"] = time.time() - begin
        reporting.write_json(os.path.join(args.out, "flexible_water.json"), data)
        print_summary(data["summary"], data["faithful_langevin"])
    # The first seed's records, under the key that earlier readers of this JSON use.
    data["peers"] = data["seeds"][0]["peers"]
    reporting.write_json(os.path.join(args.out, "flexible_water.json"), data)
    plot_all(data, args.out)
    print(markdown_tables(data))
    print("wall time %.0f s" % (time.time() - begin))


if __name__ == "__main__":
    main()

"""Smoke test of examples/drude_water: the --quick run of SWM4-NDP water with every peer writes its JSON and PNG, and
the exact-flow runs keep rigid, polarized water."""
import json
import math
import os
import subprocess
import sys

import conftest
import numpy as np
import openmm
import openmm.unit as unit
import pytest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO_ROOT, "examples", "drude_water", "drude_water.py")
HEAT_MODEL = os.path.join(REPO_ROOT, "examples", "drude_water", "heat_model.py")


def _load(path):
    """A scene script as a module (its functions, without running main)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location(os.path.splitext(os.path.basename(path))[0], path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
def _run_analysis(script, out, *arguments):
    """An analysis script (one without --quick) run with the arguments and --out OUT in a child process."""
    return subprocess.run([sys.executable, script, *arguments, "--out", str(out)], capture_output=True, text=True, encoding="utf-8",
                          timeout=120, env=dict(os.environ, MPLBACKEND="Agg"))


def _analysis_report(script, out, *arguments):
    """The JSON report that the analysis script writes to OUT (named after the script)."""
    result = _run_analysis(script, out, *arguments)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(os.path.join(out, os.path.splitext(os.path.basename(script))[0] + ".json")) as f:
        return json.load(f)


OBSERVABLES = ["induced_ratio", "dipole", "pe_per_molecule", "g_oo_peak", "t_com", "t_drude"]


def test_drude_water_quick(tmp_path):
    # With a DrudeLangevin peer with the hard wall (setMaxDrudeDistance) at 2 fs, which may fail: then the step it
    # failed at is recorded and the scene goes on.
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--wall-steps", "2"))
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "drude_water.png").stat().st_size > 10000
    with open(tmp_path / "drude_water.json") as f:
        data = json.load(f)
    runs = data["runs"]
    expected = {"DrudeLangevin_0.5fs", "DrudeLangevin_1fs", "DrudeLangevinWall_2fs"} | {
        f"{k}_{h}fs" for k in ("Strang", "Filtered", "Warped") for h in ("1", "2", "4")}
    assert set(runs) == expected
    wall = runs["DrudeLangevinWall_2fs"]
    if "failed" in wall:
        assert 1 <= wall["failed_at_step"] <= wall["failed_by_step"], wall
        assert wall["failed_at_fs"] == 2 * wall["failed_at_step"]
    for label, run in runs.items():
        if label == "DrudeLangevinWall_2fs" and "failed" in run:
            continue
        if "failed" in run:
            # Beyond omega H = pi (4 fs) a run may fall apart; it is reported, not hidden.
            assert run["step_fs"] > 3, (label, run["failed"])
            continue
        assert run["ns_per_day"] > 0 and run["steps"] > 0
        for key in OBSERVABLES:
            value, error = run[key]
            assert math.isfinite(value) and error >= 0, (label, key)
    # Loose sanity bounds on the short run (not the benchmark's claims): self-consistent polarization and cold
    # Drudes for the reference and for Filtered and Warped at 2 fs.
    for label in ("DrudeLangevin_0.5fs", "Filtered_2fs", "Warped_2fs"):
        assert abs(runs[label]["induced_ratio"][0] - 1) < 0.05, label
        assert runs[label]["t_drude"][0] < 20, label


def test_seed_summary_pools_the_stored_phase_limit_runs(tmp_path):
    """--seed-summary on the scene's stored runs: the pooled mean and standard error over the seeds, recomputed here
    from the JSON files, and the chart."""
    stored = os.path.join(REPO_ROOT, "examples", "drude_water", "results", "phase_limit")
    paths = sorted(os.path.join(stored, name) for name in os.listdir(stored) if name.startswith("seed3"))
    assert len(paths) == 8
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--seed-summary", *paths))
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "seed_summary.png").stat().st_size > 10000
    with open(tmp_path / "seed_summary.json") as f:
        summary = json.load(f)
    runs = []
    for path in paths:
        with open(path) as f:
            runs.append(json.load(f)["runs"])
    for label in ("DrudeLangevin_0.125fs", "WarpedMiddleLimited_3fs", "DrudeLangevinHeavy_3fs"):
        values = [r[label]["dipole"][0] for r in runs if label in r]
        mean = sum(values) / len(values)
        error = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1) / len(values))
        assert summary["runs"][label]["dipole"] == [pytest.approx(mean), pytest.approx(error), len(values)]
    ref, run = summary["runs"]["DrudeLangevin_0.125fs"]["dipole"], summary["runs"]["WarpedMiddleLimited_3fs"]
    assert run["dipole_t"] == pytest.approx((run["dipole"][0] - ref[0]) / math.hypot(run["dipole"][1], ref[1]))
    assert "| WarpedMiddleLimited | 4 |" in result.stdout


def test_a_negative_seed_offset_is_rejected(tmp_path):
    conftest.assert_cli_rejects(SCRIPT, tmp_path, ("--seed", "-1"), "--seed must be non-negative (got -1)")


def test_interleaved_timing_needs_a_round(tmp_path):
    conftest.assert_cli_rejects(SCRIPT, tmp_path, ("--interleaved-timing", "0"),
                                "--interleaved-timing needs at least 1 round (got 0)")


def test_cold_hot_pairs_need_two_pairs_and_the_drude_friction_must_be_positive(tmp_path):
    conftest.assert_cli_rejects(SCRIPT, tmp_path, ("--cold-hot-pairs", "1"),
                                "--cold-hot-pairs needs at least 2 pairs (got 1)")
    conftest.assert_cli_rejects(SCRIPT, tmp_path, ("--drude-friction", "0"), "--drude-friction must be positive (got 0)")


def test_step_end_velocity_variance_is_one_minus_omega_h_squared_over_six():
    # The stationary step-end <v^2>/kT of K(h/2) E(h) K(h/2) for a harmonic motion, with the friction in the free flow
    # E, against the closed form 1 - (omega h)^2/6 (friction 5/ps changes it by less than 1e-6 here); and 1 for
    # omega = 0, where the kicks vanish.
    module = _load(SCRIPT)
    for omega, h in [(40.0, 0.002), (150.0, 0.0025), (200.0, 0.002)]:
        assert abs(module.step_end_velocity_variance(omega, h) - (1 - (omega * h)**2 / 6)) < 2e-6
    assert abs(module.step_end_velocity_variance(0.0, 0.0025) - 1) < 1e-12


def test_heavy_drudes_have_the_reduced_mass_of_the_phase_limited_sim():
    # DrudeLangevinHeavy's System: every pair keeps its total mass and gets the reduced mass k/omega_d^2 with
    # omega_d = 2 sin(phi/2)/H, k = ONE_4PI_EPS0 q^2/alpha from the DrudeForce; a mass no pair can have is refused.
    module = _load(SCRIPT)
    system, _, _, _ = module.build_water(8)
    heavy, mass, ratio = module.heavy_drude_system(system, module.response_frequency(3.5, 2.05))
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
    omega_d = 2 * math.sin(1.025) / 0.0035
    for i in range(drude.getNumParticles()):
        particle, core, _, _, _, charge, alpha, _, _ = drude.getParticleParameters(i)
        k = 138.935457644382 * charge.value_in_unit(unit.elementary_charge)**2 / alpha.value_in_unit(unit.nanometer**3)
        before = [system.getParticleMass(j).value_in_unit(unit.dalton) for j in (particle, core)]
        after = [heavy.getParticleMass(j).value_in_unit(unit.dalton) for j in (particle, core)]
        assert sum(after) == pytest.approx(sum(before), rel=1e-12)
        assert after[0] * after[1] / sum(after) == pytest.approx(k / omega_d**2, rel=1e-10)
        assert after[0] == pytest.approx(mass, abs=1e-6) and after[0] > before[0]
        assert ratio == pytest.approx(before[0] * before[1] / sum(before) * omega_d**2 / k, rel=1e-8)
    with pytest.raises(ValueError, match="no Drude mass gives the reduced mass"):
        module.heavy_drude_system(system, module.response_frequency(40.0, 2.05))


def test_the_least_heavy_drudes_respond_at_2_over_h_with_the_friction_force_kept():
    # DrudeLangevinLeastHeavy at H: omega_d = 2/H (the phase pi), the Drude friction scaled by the true over the new
    # reduced mass, (omega_d/omega)^2 with omega = sqrt(k/mu); refused where 2/H exceeds omega (below 1.93 fs).
    module = _load(SCRIPT)
    system, _, _, _ = module.build_water(8)
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
    particle, core, _, _, _, charge, alpha, _, _ = drude.getParticleParameters(0)
    k = 138.935457644382 * charge.value_in_unit(unit.elementary_charge)**2 / alpha.value_in_unit(unit.nanometer**3)
    masses = [system.getParticleMass(j).value_in_unit(unit.dalton) for j in (particle, core)]
    omega = math.sqrt(k * sum(masses) / (masses[0] * masses[1]))
    assert 1030 < omega < 1040
    for step_fs in (3.0, 3.5):
        heavy, mass, scale = module.heavy_peer(system, "DrudeLangevinLeastHeavy", step_fs)
        after = [heavy.getParticleMass(j).value_in_unit(unit.dalton) for j in (particle, core)]
        assert after[0] * after[1] / sum(after) == pytest.approx(k * (step_fs * 1e-3 / 2)**2, rel=1e-10)
        assert scale == pytest.approx((2 / (step_fs * 1e-3 * omega))**2, rel=1e-8)
        _, heavier, unscaled = module.heavy_peer(system, "DrudeLangevinHeavy", step_fs)
        assert heavier > mass and unscaled == 1.0
    with pytest.raises(ValueError, match="can keep the Drude's own mass"):
        module.heavy_peer(system, "DrudeLangevinLeastHeavy", 1.9)


def test_table_reprints_the_readme_rows_from_the_stored_runs(tmp_path):
    results = os.path.join(REPO_ROOT, "examples", "drude_water", "results")
    stored = [os.path.join(results, name) for name in ("hard_wall_peers.json", "hard_wall_interleaved_timing.json")]
    result = conftest.run_quick(SCRIPT, tmp_path, extra=("--table", *stored))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(os.path.join(REPO_ROOT, "examples", "drude_water", "README.md"), encoding="utf-8") as f:
        readme = f.read()
    rows = [line for line in result.stdout.splitlines() if line.startswith("| DrudeLangevin")]
    assert rows and all(row in readme for row in rows)


def test_heat_model_the_sims_cooling_is_a_heavier_drudes_and_scaling_removes_most_of_it(tmp_path):
    """heat_model.py's exact stationary temperatures (docs/sim_drude.md section 7): the SIM's soft mode within 0.3 K
    of the true dynamics with a (omega/omega_d)^2-heavier Drude at every step, the scaled SIM at least 70 % closer to
    the true dynamics than the unscaled one."""
    model = _analysis_report(HEAT_MODEL, tmp_path)
    true = model["true_temperature_K"]
    assert len(model["rows"]) == 7
    for row in model["rows"]:
        assert abs(row["sim"] - row["heavier_drude"]) < 0.3, row
        assert true - row["sim_scaled"] < 0.3 * (true - row["sim"]), row
    assert (tmp_path / "heat_model.png").stat().st_size > 10000


PROBE = os.path.join(REPO_ROOT, "examples", "drude_water", "temperature_probe.py")


def _temperature_probe_module():
    sys.path.insert(0, os.path.dirname(PROBE))
    return _load(PROBE)


def test_temperature_classes_of_rigidly_translating_molecules_are_all_translational():
    # Every particle of molecule m moving with u_m: no rotation, no Drude motion, the translational temperature
    # sum M_m u_m^2 / ((3N - 3) k), and T_COM's kinetic energy that same sum over its own degrees of freedom.
    module = _temperature_probe_module()
    drude_water = module.drude_water
    system, _, _, _ = drude_water.build_water(8)
    analysis = drude_water.Analysis(system)
    blocks = np.array(analysis.blocks)
    u = np.random.default_rng(5).normal(size=(len(blocks), 3))
    v = np.zeros((system.getNumParticles(), 3))
    for m, block in enumerate(blocks):
        v[block] = u[m]
    t_com, t_trans, t_rot, t_drude = module.temperature_classes(analysis, analysis.masses, blocks, v)
    kinetic = 0.5 * np.sum(analysis.masses[blocks].sum(axis=1)[:, None] * u**2)
    assert t_trans == pytest.approx(2 * kinetic / ((3 * len(blocks) - 3) * drude_water.BOLTZ), rel=1e-12)
    assert t_com == pytest.approx(2 * kinetic / (analysis.com_dof * drude_water.BOLTZ), rel=1e-12)
    assert abs(t_rot) < 1e-9 * t_trans and t_drude == 0.0


def test_temperature_probe_quick_writes_every_peer(tmp_path):
    result = conftest.run_quick(PROBE, tmp_path, timeout=300,
                                extra=("--peers", "DrudeLangevin:1:1", "WarpedMiddleLimitedScaled:2.5:300"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "temperature_probe.json") as f:
        report = json.load(f)
    assert list(report["peers"]) == ["DrudeLangevin_1fs_Drudes1K", "WarpedMiddleLimitedScaled_2.5fs_Drudes300K"]
    for peer in report["peers"].values():
        for name in ("t_com", "t_translational", "t_rotational", "t_drude"):
            assert math.isfinite(peer[name][0]) and peer[name][1] >= 0
    # A 300-K Drude bath holds the Drudes near 300 K, a 1-K bath near 1 K.
    assert report["peers"]["DrudeLangevin_1fs_Drudes1K"]["t_drude"][0] < 20
    assert report["peers"]["WarpedMiddleLimitedScaled_2.5fs_Drudes300K"]["t_drude"][0] > 100


def test_neutral_drudes_leave_no_field_on_the_drude_particles():
    # After neutral_drudes the nonbonded forces on every Drude particle vanish (no charge, no Lennard-Jones), the
    # System's charge is unchanged and the Drude springs are untouched.
    module = _temperature_probe_module()
    system, _, positions, _ = module.drude_water.build_water(8)
    nonbonded = next(f for f in system.getForces() if isinstance(f, openmm.NonbondedForce))
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))

    def total_charge():
        return sum(nonbonded.getParticleParameters(i)[0].value_in_unit(unit.elementary_charge)
                   for i in range(system.getNumParticles()))
    before = total_charge()
    springs = [drude.getParticleParameters(i) for i in range(drude.getNumParticles())]
    module.neutral_drudes(system)
    assert total_charge() == pytest.approx(before, abs=1e-12)
    assert [drude.getParticleParameters(i) for i in range(drude.getNumParticles())] == springs
    context = openmm.Context(system, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions)
    context.computeVirtualSites()
    forces = context.getState(getForces=True, groups={0}).getForces(asNumpy=True).value_in_unit(
        unit.kilojoule_per_mole / unit.nanometer)
    particles = [drude.getParticleParameters(i)[0] for i in range(drude.getNumParticles())]
    assert np.abs(forces[particles]).max() < 1e-9
    assert np.abs(forces).max() > 1.0


@pytest.mark.parametrize("peer, message", [("Warped:2.5", "expected KIND:H:DRUDE_K"),
                                           ("Verlet:2.5:1", "unknown kind 'Verlet'"),
                                           ("DrudeLangevinWall:1:1", "unknown kind"),
                                           ("Warped:-1:1", "must be positive")])
def test_temperature_probe_rejects_a_bad_peer(tmp_path, peer, message):
    conftest.assert_cli_rejects(PROBE, tmp_path, ("--peers", peer), message)


def test_temperature_probe_runs_a_heavier_drude_twin_on_its_own_masses(tmp_path):
    # The twin of a SIM step that flows the Drude by 1 rad at 2.5 fs: Drude particles (2.59 / (2 sin 0.5))^2 times
    # the reduced mass, the twin's temperatures from its own masses (a 1-K Drude bath holds its Drudes cold).
    result = conftest.run_quick(PROBE, tmp_path, timeout=300, extra=("--peers", "DrudeLangevin:1:1", "--twin-of",
                                                                     "2.5:1.0"))
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "temperature_probe.json") as f:
        report = json.load(f)
    assert list(report["peers"]) == ["DrudeLangevin_1fs_Drudes1K_twin"] and report["twin_of"] == "2.5:1.0"
    module = _temperature_probe_module()
    system, _, _, _ = module.drude_water.build_water(8)
    _, mass, ratio = module.drude_water.heavy_drude_system(system, module.drude_water.response_frequency(2.5, 1.0))
    assert report["twin_drude_mass_amu"] == pytest.approx(mass)
    assert 1 / ratio == pytest.approx((1036.0 * 2.5e-3 / (2 * math.sin(0.5)))**2, rel=2e-3)
    peer = report["peers"]["DrudeLangevin_1fs_Drudes1K_twin"]
    assert all(math.isfinite(peer[name][0]) for name in ("t_com", "t_translational", "t_rotational"))
    assert peer["t_drude"][0] < 50


@pytest.mark.parametrize("option, value, message", [
    ("--drude-friction", "0", "--drude-friction must be positive (got 0)"),
    ("--max-warped-phase", "3.5", "--max-warped-phase must be in (0, pi) (got 3.5)"),
    ("--twin-of", "2.5", "--twin-of '2.5': expected H:PHASE"),
    ("--twin-of", "2.5:4", "--twin-of '2.5:4': H must be positive and PHASE in (0, pi]")])
def test_temperature_probe_rejects_a_bad_setting(tmp_path, option, value, message):
    conftest.assert_cli_rejects(PROBE, tmp_path, ("--peers", "DrudeLangevin:1:1", option, value), message)


@pytest.mark.long
def test_heat_model_what_scaling_leaves_is_the_heavier_drudes_dressing_and_does_not_follow_the_friction(tmp_path):
    """heat_model.py --friction (docs/sim_drude.md section 7): what the scaled SIM leaves is the dressing of the soft
    mode by a Drude (m - 1) times heavier, a kinetic-energy deficit of (m - 1) r (Omega/omega)^2 of the temperature
    (to 15 %), about the same at the soft mode's friction 5 and 20/ps; the unscaled SIM's deficit, mostly heat drawn,
    falls by more than half from 5 to 20/ps."""
    deficits = {}
    for friction in (5, 20):
        out = tmp_path / str(friction)
        model = _analysis_report(HEAT_MODEL, out, "--friction", str(friction))
        assert model["friction_per_ps"] == friction
        true = model["true_temperature_K"]
        dressing = model["r"] * (model["omega_y_per_ps"] / 1036.0)**2 * true
        for row in model["rows"]:
            if row["step_fs"] in (2.5, 3.5):
                predicted = (row["mass_factor"] - 1) * dressing
                assert abs((true - row["sim_scaled"]) - predicted) < 0.15 * predicted, row
                deficits[(friction, row["step_fs"])] = (true - row["sim"], true - row["sim_scaled"])
    for step_fs in (2.5, 3.5):
        assert deficits[(20, step_fs)][0] < 0.5 * deficits[(5, step_fs)][0]
        assert deficits[(20, step_fs)][1] > 0.8 * deficits[(5, step_fs)][1]
    rejected = _run_analysis(HEAT_MODEL, tmp_path, "--friction", "0")
    assert rejected.returncode != 0 and "--friction must be positive" in rejected.stderr


FORCE_HISTORY = os.path.join(REPO_ROOT, "examples", "drude_water", "force_history.py")


def _slow_response(module, trace, det, ratio, h, history=False, coupling=0.0):
    """(static value, Omega^2 coefficient relative to it) of force_history.response: Richardson on the real part at
    Omega = 4 and 8/ps, whose error is O(Omega^4)."""
    static = module.response(trace, det, ratio, h, 0.0, history, coupling).real
    low, high = (module.response(trace, det, ratio, h, w, history, coupling).real / static - 1 for w in (4.0, 8.0))
    return static, (16 * low - high) / 192


def _force_history_module():
    sys.path.insert(0, os.path.dirname(FORCE_HISTORY))
    return _load(FORCE_HISTORY)


@pytest.mark.parametrize("step_fs", [2.5, 3.5])
def test_the_history_term_makes_the_slow_response_exact_to_omega_squared_and_leads_by_its_cube(step_fs):
    # docs/sim_drude.md section 8: omega^2 x / f = 1 + (Omega / omega_d)^2 + ... without the term, with
    # omega_d^2 = 2 (1 + D - T) / ((1 + D) H^2); with it 1 + (Omega / omega)^2 + ..., and the term adds
    # i (b2 / b) (Omega H)^3 to leading order.  Without friction, whose own O((gamma / omega)^2) terms the expansion
    # leaves out.
    module = _force_history_module()
    h, omega = step_fs * 1e-3, 1036.0
    trace, det, ratio = module.recurrence(h, scaled=False, drude_friction=1e-9)
    omega_d2 = 2 * (1 + det - trace) / ((1 + det) * h * h)

    assert _slow_response(module, trace, det, ratio, h)[1] == pytest.approx(1 / omega_d2, rel=1e-5)
    assert _slow_response(module, trace, det, ratio, h, history=True)[1] == pytest.approx(1 / omega**2, rel=1e-5)
    assert omega_d2 < 0.6 * omega**2
    field = 10.0
    lead = (module.response(trace, det, ratio, h, field, True) - module.response(trace, det, ratio, h, field, False))
    assert lead.imag == pytest.approx(ratio * (field * h)**3, rel=2e-2)
    assert module.lead_friction(ratio, h, field) == pytest.approx(-ratio * omega**2 * field**2 * h**3)


@pytest.mark.parametrize("step_fs", [2.5, 3.0, 3.5, 4.0])
def test_the_history_term_destabilizes_every_softening_mode_that_the_bath_does_not_damp(step_fs):
    # To first order in lambda the oscillating roots move by -lambda s^2 (b2 / b) / 2 in modulus (s = 1 + D - T)
    # from sqrt(D): without friction any lambda < 0 is unstable, with it the edge is -2 (1 - sqrt D) / (s^2 b2 / b).
    # Without the term the edge on the stiff side is |T - lambda s| = 1 + D.
    module = _force_history_module()
    h = step_fs * 1e-3
    trace, det, ratio = module.recurrence(h, scaled=False, drude_friction=1e-9)
    s = 1 + det - trace
    epsilon = 1e-6
    growth = (module.spectral_radius(trace, det, ratio, -epsilon) - 1) / epsilon
    assert growth == pytest.approx(s * s * ratio / 2, rel=1e-3)
    assert module.stable_interval(trace, det, ratio)[0] > -1e-3
    trace, det, ratio = module.recurrence(h, scaled=False)
    s = 1 + det - trace
    low, high = module.stable_interval(trace, det, ratio)
    assert low == pytest.approx(-2 * (1 - math.sqrt(det)) / (s * s * ratio), rel=0.1)
    assert module.stable_interval(trace, det, 0.0) == pytest.approx((-1.0, (1 + det + trace) / s), abs=1e-9)


@pytest.mark.long
def test_force_history_the_lead_heats_the_molecules_and_the_coupling_needs_a_small_phase(tmp_path):
    """force_history.py: with the friction scaled, the term heats heat_model.py's soft mode as a Drude friction of
    -(b2 / b) omega^2 Omega^2 H^3 would (to 15 %); stable over SWM4-NDP's lambda only at flow phases below 0.5, where
    that friction exceeds 1000/ps."""
    report = _analysis_report(FORCE_HISTORY, tmp_path)
    true = report["true_temperature_K"]
    assert [row["step_fs"] for row in report["rows"]] == [2.5, 3.0, 3.5, 4.0]
    for row in report["rows"]:
        heating = row["scaled"]["soft_mode_with_history_K"] - true
        predicted = row["predicted_with_history_K"] - true
        assert heating > 1.0 and abs(heating - predicted) < 0.15 * predicted, row
        assert row["scaled"]["soft_mode_K"] < true
        cover = row["largest_phase_covering"]
        assert cover["phase"] < 0.5 and cover["lead_friction_per_ps"] < -1000, row
        assert row["friction_holding_per_ps"] > 25 * 20, row
    assert (tmp_path / "force_history.png").stat().st_size > 20000


def test_force_history_rejects_a_coupling_outside_0_1(tmp_path):
    result = _run_analysis(FORCE_HISTORY, tmp_path, "--r", "1.5")
    assert result.returncode != 0 and "--r must be in (0, 1) (got 1.5)" in result.stderr


@pytest.mark.parametrize("step_fs", [2.0, 3.0])
@pytest.mark.parametrize("coupling", [0.40, -0.42])
def test_an_anisotropic_remainder_left_soft_keeps_the_mean_and_the_isotropic_flows_inertia(step_fs, coupling):
    # A soft stiffness lambda k along a Drude mode (Drude-2019's anisotropic remainders: -0.42 to +0.40) kicked with
    # the field, the flow that of the isotropic spring limited to the drude_protein scene's phase 1.77: the static
    # response is the exact 1/(k (1 + lambda)) and the mass factor (the Omega^2 term against the true
    # 1/((1 + lambda) omega^2)) the isotropic flow's.  Taken into the flow instead (frequency sqrt(1 + lambda) omega,
    # its own warped phase, limited alike) the factor is (1 + lambda) omega^2 / omega_d'^2 with omega_d'^2 = s' / H^2:
    # (1 + lambda) times the soft one where both flows sit at the limit.  No friction, whose O((gamma/omega)^2)
    # terms the expansion leaves out.
    module = _force_history_module()
    heat_model = module.heat_model
    h, omega, max_phase = step_fs * 1e-3, 1036.0, 1.77

    def flow(frequency):
        phi, _ = heat_model.mode_flow(min(heat_model.warped_frequency(frequency, 0.0, h), max_phase / h), 0.0, h)
        return np.trace(phi), np.linalg.det(phi)

    def expansion(trace, det, lam, frequency):
        # (static response x / f, Omega^2 coefficient relative to it), the step's mean set for frequency.
        static, relative = _slow_response(module, trace, det, 0.0, h, coupling=lam)
        return static / frequency**2, relative
    isotropic = flow(omega)
    soft_static, soft_relative = expansion(*isotropic, coupling, omega)
    _, isotropic_relative = expansion(*isotropic, 0.0, omega)
    assert soft_static * omega**2 * (1 + coupling) == pytest.approx(1.0, abs=1e-12)
    soft_mass = soft_relative * (1 + coupling) * omega**2
    assert soft_mass == pytest.approx(isotropic_relative * omega**2, rel=1e-5)
    stiff = flow(math.sqrt(1 + coupling) * omega)
    stiff_static, stiff_relative = expansion(*stiff, 0.0, math.sqrt(1 + coupling) * omega)
    assert stiff_static * omega**2 * (1 + coupling) == pytest.approx(1.0, abs=1e-12)
    stiff_mass = stiff_relative * (1 + coupling) * omega**2
    assert stiff_mass == pytest.approx((1 + coupling) * omega**2 * h * h / (2 - stiff[0]), rel=1e-5)
    if step_fs == 3.0:
        # Both flows at the phase limit: the same trace, and the remainder in the flow (1 + lambda) times as heavy.
        assert stiff[0] == pytest.approx(isotropic[0], abs=1e-12)
        assert stiff_mass == pytest.approx((1 + coupling) * soft_mass, rel=1e-5)
    assert (stiff_mass > soft_mass) == (coupling > 0)

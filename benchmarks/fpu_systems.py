"""Shared pieces of benchmarks/work_precision.py and benchmarks/stability.py.

- The FPU chain (FLAVORS paper eq. 6.7; Hairer-Lubich-Wanner, Geometric Numerical Integration, section I.5) as an
  OpenMM System and its slow/fast observables (from examples/common/fpu_chain.py), and its two initial conditions.
- The two-mass linear system (5.1) of the FLAVORS paper.
- A high-accuracy reference for the FPU chain that shares no code with OpenMM or this plugin: an 8th-order
  triple-jump composition of velocity Verlet (Yoshida 1990) written in C, compiled at first use with the system's C
  compiler and called through ctypes.  If no compiler is found, scipy's DOP853 (much slower) is used instead.
- The methods compared, their force-evaluation counts, and a runner that samples any of them at given times.

Units are OpenMM's, read as the papers' dimensionless ones (mass 1 amu, length 1 nm, time 1 ps, energy 1 kJ/mol).
"""
import ctypes
import hashlib
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import openmm as mm
import openmm.unit as unit
from openmm import mtsintegrator

import openmmflavors

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples", "common"))
from fpu_chain import SOFT_GROUP, SQRT2, STIFF_GROUP, fpu_system, from_slow_fast, observables  # noqa: E402,F401
from fpu_chain import leapfrog_start, masses_of, synchronized  # noqa: E402,F401
from scene import jsonable  # noqa: E402,F401  (strict JSON: inf and nan become null)

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# ----------------------------------------------------------------------------------------------------------------------
# Systems

def fpu_initial(m, omega, setup):
    """(q, v) on the x axis, each of length 2m.

    'hlw':   Hairer-Lubich-Wanner (GNI section I.5.1): x0,1 = 1, y0,1 = 1, x1,1 = 1/omega, y1,1 = 1, others 0.
    'paper': FLAVORS Fig. 6.5: x0 = (1, 0, 0), x1 = (1/omega, 0, 0), y = 0.
    x0,i = (q_2i + q_2i-1)/sqrt2 (slow), x1,i = (q_2i - q_2i-1)/sqrt2 (fast); y the same for the velocities.
    """
    x0, x1, y0, y1 = (np.zeros(m) for _ in range(4))
    x0[0], x1[0] = 1.0, 1.0 / omega
    if setup == "hlw":
        y0[0], y1[0] = 1.0, 1.0
    elif setup != "paper":
        raise ValueError(f"unknown FPU setup {setup!r}")
    return from_slow_fast(x0, x1), from_slow_fast(y0, y1)


def as_vec3(x, y=0.0):
    out = np.zeros((len(x), 3))
    out[:, 0] = x
    out[:, 1] = y
    return out


def fpu_energy(q, v, omega):
    """Total energy of one chain (eq. 6.7) from its x coordinates and velocities."""
    d = np.diff(np.concatenate(([0.0], q, [0.0])))
    return 0.5 * np.sum(v * v) + 0.25 * omega * omega * np.sum(d[1::2] ** 2) + np.sum(d[0::2] ** 4)


def two_mass_system(omega):
    """System (5.1): H = px^2/2 + py^2/2 + x^2/2 + omega^2/2 (y - x)^2.  Particle 0 is x, particle 1 is y."""
    system = mm.System()
    system.addParticle(1.0)
    system.addParticle(1.0)
    soft = mm.CustomExternalForce("0.5*x^2")
    soft.addParticle(0)
    soft.setForceGroup(SOFT_GROUP)
    stiff = mm.HarmonicBondForce()
    stiff.addBond(0, 1, 0.0, omega * omega)
    stiff.setForceGroup(STIFF_GROUP)
    system.addForce(soft)
    system.addForce(stiff)
    return system


# ----------------------------------------------------------------------------------------------------------------------
# Reference solution

_C_SOURCE = r"""
#include <math.h>
/* FPU chain eq. (6.7), n = 2m particles: walls x^4 on particles 0 and n-1, soft r^4 between (2i+1, 2i+2), stiff
   omega^2/4 r^2 between (2i, 2i+1).  Forces into f. */
static void forces(int n, double half_w2, const double *q, double *f) {
    for (int k = 0; k < n; k++) f[k] = 0.0;
    f[0] -= 4.0 * q[0] * q[0] * q[0];
    f[n - 1] -= 4.0 * q[n - 1] * q[n - 1] * q[n - 1];
    for (int a = 0; a + 1 < n; a++) {
        double r = q[a + 1] - q[a];
        double g = (a % 2 == 0) ? half_w2 * r : 4.0 * r * r * r;
        f[a] += g;
        f[a + 1] -= g;
    }
}

/* Compensated (Kahan) update x += dx, c the running compensation. */
static inline void kadd(double *x, double *c, double dx) {
    double y = dx - *c;
    double t = *x + y;
    *c = (t - *x) - y;
    *x = t;
}

/* One step of length h of the composition sum_s coef[s] of velocity-Verlet substeps (kick-drift-kick), with the
   first kick of each substep reusing the force of the previous one. */
static void step(int n, double half_w2, double *q, double *v, double *cq, double *cv, double *f, double h,
                 int ns, const double *coef) {
    for (int s = 0; s < ns; s++) {
        double hs = coef[s] * h;
        for (int k = 0; k < n; k++) kadd(&v[k], &cv[k], 0.5 * hs * f[k]);
        for (int k = 0; k < n; k++) kadd(&q[k], &cq[k], hs * v[k]);
        forces(n, half_w2, q, f);
        for (int k = 0; k < n; k++) kadd(&v[k], &cv[k], 0.5 * hs * f[k]);
    }
}

/* Integrate from time 0 with step h and write (q, v) at each of the nt increasing times into out (nt x 2n).
   A segment that is not a multiple of h ends with one shorter step.  n <= 64. */
int fpu_reference(int n, double omega, const double *q0, const double *v0, int nt, const double *times, double h,
                  int ns, const double *coef, double *out) {
    double q[64], v[64], cq[64], cv[64], f[64];
    if (n > 64) return -1;
    double half_w2 = 0.5 * omega * omega;
    for (int k = 0; k < n; k++) { q[k] = q0[k]; v[k] = v0[k]; cq[k] = 0.0; cv[k] = 0.0; }
    forces(n, half_w2, q, f);
    double t = 0.0;
    for (int j = 0; j < nt; j++) {
        double span = times[j] - t;
        long steps = (long)floor(span / h);
        for (long s = 0; s < steps; s++) step(n, half_w2, q, v, cq, cv, f, h, ns, coef);
        double rest = span - steps * h;
        if (rest > 1e-14 * h) step(n, half_w2, q, v, cq, cv, f, rest, ns, coef);
        t = times[j];
        for (int k = 0; k < n; k++) { out[2 * n * j + k] = q[k]; out[2 * n * j + n + k] = v[k]; }
        if (!isfinite(q[0])) return 1;
    }
    return 0;
}
"""

_LIBRARY = None


def triple_jump(order):
    """Substep weights of the Suzuki-Yoshida triple jump: velocity Verlet composed up to the given even order."""
    coef = [1.0]
    for p in range(2, order, 2):
        g1 = 1.0 / (2.0 - 2.0 ** (1.0 / (p + 1)))
        g0 = 1.0 - 2.0 * g1
        coef = [g1 * c for c in coef] + [g0 * c for c in coef] + [g1 * c for c in coef]
    return np.array(coef)


def _compile():
    global _LIBRARY
    if _LIBRARY is not None:
        return _LIBRARY
    compiler = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc") or shutil.which("clang")
    if compiler is None:
        _LIBRARY = False
        return _LIBRARY
    digest = hashlib.sha1(_C_SOURCE.encode()).hexdigest()[:12]
    directory = os.path.join(tempfile.gettempdir(), f"openmmflavors_fpu_ref_{os.getuid()}")
    os.makedirs(directory, exist_ok=True)
    path = os.path.join(directory, f"fpu_ref_{digest}.so")
    if not os.path.exists(path):
        source = os.path.join(directory, f"fpu_ref_{digest}.c")
        with open(source, "w") as f:
            f.write(_C_SOURCE)
        partial = f"{path}.{os.getpid()}"
        # No -ffast-math: the compensated sums must not be reassociated away.
        result = subprocess.run([compiler, "-O2", "-shared", "-fPIC", "-o", partial, source, "-lm"],
                                capture_output=True, text=True)
        if result.returncode != 0:
            print(f"compiling the reference integrator failed, using scipy instead:\n{result.stderr}", file=sys.stderr)
            _LIBRARY = False
            return _LIBRARY
        os.replace(partial, path)
    library = ctypes.CDLL(path)
    pointer = ctypes.POINTER(ctypes.c_double)
    library.fpu_reference.argtypes = [ctypes.c_int, ctypes.c_double, pointer, pointer, ctypes.c_int, pointer,
                                      ctypes.c_double, ctypes.c_int, pointer, pointer]
    library.fpu_reference.restype = ctypes.c_int
    _LIBRARY = library
    return _LIBRARY


def _as_pointer(array):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def reference_composition(q0, v0, omega, times, h, order=8):
    """(q, v) at `times` (increasing, > 0) by the compiled triple-jump composition of the given order with step h."""
    library = _compile()
    if not library:
        return None
    n = len(q0)
    q0, v0 = np.ascontiguousarray(q0, float), np.ascontiguousarray(v0, float)
    times = np.ascontiguousarray(times, float)
    coef = np.ascontiguousarray(triple_jump(order))
    out = np.empty((len(times), 2 * n))
    status = library.fpu_reference(n, float(omega), _as_pointer(q0), _as_pointer(v0), len(times), _as_pointer(times),
                                   float(h), len(coef), _as_pointer(coef), _as_pointer(out))
    if status != 0:
        raise RuntimeError(f"reference integration failed (status {status})")
    return out[:, :n], out[:, n:]


def reference_dop853(q0, v0, omega, times, rtol=1e-12):
    """(q, v) at `times` with scipy's DOP853 (NumPy right-hand side)."""
    from scipy.integrate import solve_ivp
    n = len(q0)
    half_w2 = 0.5 * omega * omega

    def rhs(_, s):
        q = s[:n]
        d = np.diff(np.concatenate(([0.0], q, [0.0])))
        g = np.empty(n + 1)
        g[0::2] = 4.0 * d[0::2] ** 3
        g[1::2] = half_w2 * d[1::2]
        return np.concatenate((s[n:], g[1:] - g[:-1]))

    result = solve_ivp(rhs, (0.0, times[-1]), np.concatenate((q0, v0)), method="DOP853", rtol=rtol,
                       atol=rtol * 1e-3, t_eval=times)
    return result.y[:n].T, result.y[n:].T


def reference(q0, v0, omega, times, steps_per_period=None):
    """High-accuracy FPU solution at `times` and an estimate of its own error.

    The compiled 8th-order composition runs twice, at h and 2h; h is 1/40 of the fast period by default (omega h =
    0.16; the substeps reach |1.9 h|).  Its error at h is bounded by the difference of the two runs (for an 8th-order
    method the error at h is about 1/255 of it).  Returns dict(q, v, h, method, self_check: (q, v) of the 2h run).
    Falls back to DOP853 at rtol 1e-12 and 1e-13 when no C compiler is available.
    """
    times = np.asarray(times, float)
    steps_per_period = steps_per_period or 40
    h = 2.0 * math.pi / omega / steps_per_period
    start = time.perf_counter()
    fine = reference_composition(q0, v0, omega, times, h)
    if fine is not None:
        coarse = reference_composition(q0, v0, omega, times, 2.0 * h)
        return {"q": fine[0], "v": fine[1], "q_check": coarse[0], "v_check": coarse[1], "h": h,
                "method": f"compiled C, 8th-order triple-jump composition of velocity Verlet (27 substeps), h = "
                          f"{h:.4g} (omega h = {omega * h:.3g}); check run at 2h",
                "wall_s": time.perf_counter() - start}
    fine = reference_dop853(q0, v0, omega, times, 1e-13)
    coarse = reference_dop853(q0, v0, omega, times, 1e-12)
    return {"q": fine[0], "v": fine[1], "q_check": coarse[0], "v_check": coarse[1], "h": None,
            "method": "scipy DOP853, rtol 1e-13; check run at rtol 1e-12", "wall_s": time.perf_counter() - start}


# ----------------------------------------------------------------------------------------------------------------------
# Methods: factories and force-evaluation counts

class Method:
    """One integrator family.  cost(): force-group evaluations per step as (soft, stiff): an all-groups evaluation
    counts once for each group."""

    def __init__(self, key, label, make, soft, stiff, leapfrog=False, color=None, marker="o"):
        self.key, self.label, self.make = key, label, make
        self.soft, self.stiff, self.leapfrog = soft, stiff, leapfrog
        self.color, self.marker = color, marker


def flavor(delta, tau, scheme):
    integrator = openmmflavors.FlavorIntegrator(delta * unit.picoseconds, tau * unit.picoseconds, {STIFF_GROUP})
    integrator.setScheme(scheme)
    return integrator


def sim(step, splitting, friction=0.0, temperature=0.0, seed=0):
    integrator = openmmflavors.StochasticImpulseIntegrator(temperature * unit.kelvin, friction / unit.picosecond,
                                                          step * unit.picoseconds, {STIFF_GROUP})
    integrator.setSplitting(splitting)
    if seed:
        integrator.setRandomNumberSeed(seed)
    return integrator


def mts(step, inner):
    # Both groups listed: MTSIntegrator silently drops any group it is not given.
    return mtsintegrator.MTSIntegrator(step * unit.picoseconds, [(SOFT_GROUP, 1), (STIFF_GROUP, inner)])


# ----------------------------------------------------------------------------------------------------------------------
# Running a method

def make_context(system, integrator, q, v, leapfrog, platform="Reference", warm_up=False):
    """A Context at (q, v).  For OpenMM's leapfrog VerletIntegrator the stored velocities are v(-h/2) = v0 - h/2 F/m,
    which makes it exactly velocity Verlet from (q, v).

    warm_up: take one step first and then set the state again, so that one-time work (SIM's measurement of the stiff
    modes, CustomIntegrator's expression compilation) is not timed with the steps.  Returns (context, warm-up s)."""
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName(platform))
    masses = masses_of(system)
    step = integrator.getStepSize().value_in_unit(unit.picoseconds)

    def set_state():
        context.setTime(0.0)
        context.setPositions(q)
        context.setVelocities(leapfrog_start(context, v, step, masses) if leapfrog else v)

    set_state()
    if not warm_up:
        return context
    start = time.perf_counter()
    integrator.step(1)
    elapsed = time.perf_counter() - start
    set_state()
    return context, elapsed


def read_state(context, leapfrog, step, masses, energy=False):
    """(q, v[, potential energy]) of particle x coordinates; leapfrog velocities are brought to the positions' time."""
    state = context.getState(getPositions=True, getVelocities=True, getForces=leapfrog, getEnergy=energy)
    q = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
    v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
    if leapfrog:
        v = synchronized(state, np.asarray(v), step, masses)
    if energy:
        return q, v, state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)
    return q, v


def run_sampled(system, integrator, q0, v0, step, sample_steps, leapfrog):
    """Run to each of the increasing step counts in sample_steps and return (q_x, v_x) there (arrays [sample,
    particle]), the cumulative wall time of the step() calls at each sample, whether the run stayed finite, and the
    wall time of the untimed warm-up step."""
    masses = masses_of(system)
    context, setup = make_context(system, integrator, as_vec3(q0), as_vec3(v0), leapfrog, warm_up=True)
    qs = np.full((len(sample_steps), len(q0)), np.nan)
    vs = np.full((len(sample_steps), len(q0)), np.nan)
    walls = np.full(len(sample_steps), np.nan)
    wall, done, finite = 0.0, 0, True
    for k, target in enumerate(sample_steps):
        if target > done:
            start = time.perf_counter()
            try:
                integrator.step(int(target - done))
            except mm.OpenMMException:
                finite = False
                break
            finally:
                wall += time.perf_counter() - start
            done = int(target)
        q, v = read_state(context, leapfrog, step, masses)
        qs[k], vs[k], walls[k] = q[:, 0], v[:, 0], wall
        if not (np.all(np.isfinite(qs[k])) and np.all(np.isfinite(vs[k])) and np.max(np.abs(qs[k])) < 1e6):
            finite = False
            qs[k:], vs[k:] = np.nan, np.nan
            break
    del context
    return qs, vs, walls, finite, setup


def nonresonant(step, omega, margin=0.25):
    """step nudged so that omega*step is at least margin*pi away from every positive multiple of pi (impulse methods
    resonate there; SIM paper section 3.3, README 'Which integrator when')."""
    k = round(omega * step / math.pi)
    if k >= 1 and abs(omega * step - k * math.pi) < margin * math.pi:
        low, high = (k - margin) * math.pi / omega, (k + margin) * math.pi / omega
        step = low if step - low <= high - step else high
    return step


def save_figure(fig, path, dpi, small=False):
    """Save a matplotlib figure; small=True quantizes it to a 64-colour palette (docs/ copies must stay small)."""
    if not small:
        fig.savefig(path, dpi=dpi)
        return
    import io
    from PIL import Image
    buffer = io.BytesIO()
    fig.savefig(buffer, dpi=dpi, format="png")
    buffer.seek(0)
    Image.open(buffer).convert("RGB").quantize(colors=64, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


class ProgressBar:
    """`[####....] 12/40 label` on stderr, one line per item."""

    def __init__(self, total, width=20, stream=sys.stderr):
        self.total, self.width, self.stream, self.done = max(1, total), width, stream, 0
        self.start = time.perf_counter()

    def step(self, label):
        self.done += 1
        filled = int(round(self.width * self.done / self.total))
        elapsed = time.perf_counter() - self.start
        print(f"[{'#' * filled}{'.' * (self.width - filled)}] {self.done}/{self.total} {label}  ({elapsed:.0f} s)",
              file=self.stream, flush=True)

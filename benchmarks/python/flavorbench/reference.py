"""The reference solution of the FPU chain, sharing no code with OpenMM or this plugin: SciPy's DOP853 (explicit
Runge-Kutta 8(5,3) with step-size control; the Fortran core of scipy.integrate.ode, with a right-hand side in plain
Python floats, which is faster than NumPy on a handful of particles).

reference() states its own error: it integrates twice, at rtol and at a looser check_rtol, and the difference of the
two runs bounds the error of the looser one and so, with room to spare, of the reference.  At rtol 1e-12 DOP853 is
at its round-off floor here: tighter tolerances take more steps and are no more accurate.
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
from scipy.integrate import ode


def _equations(omega, n, calls):
    """d(q, v)/dt of one chain of n particles (walls x^4 on particles 0 and n-1, stiff omega^2/4 r^2 between (2i,
    2i+1), soft r^4 between (2i+1, 2i+2)); calls[0] counts the evaluations."""
    k = omega * omega / 2

    def rhs(_, s):
        calls[0] += 1
        q = s[:n].tolist()
        f = [0.0] * n
        f[0] = -4 * q[0] * q[0] * q[0]
        f[n - 1] = -4 * q[n - 1] * q[n - 1] * q[n - 1]
        for a in range(n - 1):
            r = q[a + 1] - q[a]
            g = k * r if a % 2 == 0 else 4 * r * r * r
            f[a] += g
            f[a + 1] -= g
        return s[n:].tolist() + f

    return rhs


def dop853(q0, v0, omega, times, rtol, atol=1e-15):
    """One chain from (q0, v0) (x coordinates) at the increasing `times` (> 0): arrays q, v [time, particle], the wall
    seconds and the number of right-hand-side evaluations."""
    n, calls = len(q0), [0]
    start = time.perf_counter()
    solver = ode(_equations(omega, n, calls)).set_integrator("dop853", rtol=rtol, atol=atol, nsteps=10**9)
    solver.set_initial_value(np.concatenate([q0, v0]), 0.0)
    out = np.empty((len(times), 2 * n))
    for k, t in enumerate(times):
        out[k] = solver.integrate(t)
        if not solver.successful():
            raise RuntimeError(f"DOP853 failed at t = {t:g} (omega = {omega:g}, rtol = {rtol:g})")
    return out[:, :n], out[:, n:], time.perf_counter() - start, calls[0]


def reference(q0, v0, omega, times, rtol=1e-12, check_rtol=1e-10):
    """The FPU chain at `times` by DOP853 at rtol, and again at check_rtol for its own error.

    Returns dict(q, v, q_check, v_check: arrays [time, particle]; rtol, check_rtol, method, wall_s and check_wall_s,
    rhs_evaluations)."""
    times = np.asarray(times, float)
    q, v, wall, calls = dop853(q0, v0, omega, times, rtol)
    q_check, v_check, check_wall, _ = dop853(q0, v0, omega, times, check_rtol)
    return {"q": q, "v": v, "q_check": q_check, "v_check": v_check, "rtol": rtol, "check_rtol": check_rtol,
            "method": f"SciPy DOP853 (scipy.integrate.ode), rtol {rtol:g}, atol 1e-15; check run at rtol "
                      f"{check_rtol:g}",
            "wall_s": wall, "check_wall_s": check_wall, "rhs_evaluations": calls}


# The compiled 8th-order composition (work_precision.py)

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


def composition_reference(q0, v0, omega, times, steps_per_period=None):
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

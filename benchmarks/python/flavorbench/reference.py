"""The reference solution of the FPU chain, sharing no code with OpenMM or this plugin: SciPy's DOP853 (explicit
Runge-Kutta 8(5,3) with step-size control; the Fortran core of scipy.integrate.ode, with a right-hand side in plain
Python floats, which is faster than NumPy on a handful of particles).  Of the solvers SciPy offers it is the fastest
at this accuracy here: LSODA and VODE's Adams methods take fewer evaluations but stay ten times less accurate.

reference() states its own error: it integrates twice, at rtol and at a looser check_rtol, and the difference of the
two runs bounds the error of the looser one and so, with room to spare, of the reference.  At rtol 1e-12 DOP853 is
at its round-off floor here: tighter tolerances take more steps and are no more accurate.
"""
import time

import numpy as np
from scipy.integrate import ode


def _equations(omega, chains, n, calls):
    """d(q, v)/dt of `chains` independent chains of n particles (walls x^4 on particles 0 and n-1, stiff omega^2/4
    r^2 between (2i, 2i+1), soft r^4 between (2i+1, 2i+2)); state: all positions, then all velocities.  calls[0]
    counts the evaluations."""
    k = omega * omega / 2

    def rhs(_, s):
        calls[0] += 1
        y = s.tolist()
        out = y[chains * n:]
        for c in range(chains):
            q = y[c * n:(c + 1) * n]
            f = [0.0] * n
            f[0] = -4 * q[0] * q[0] * q[0]
            f[n - 1] = -4 * q[n - 1] * q[n - 1] * q[n - 1]
            for a in range(n - 1):
                r = q[a + 1] - q[a]
                g = k * r if a % 2 == 0 else 4 * r * r * r
                f[a] += g
                f[a + 1] -= g
            out += f
        return out

    return rhs


def dop853(q0, v0, omega, times, rtol, atol=1e-15):
    """Chains from (q0, v0) (x coordinates: one chain (particles,) or several (chains, particles), integrated
    together, with the same steps) at the increasing `times` (> 0).  Returns q, v (arrays [time, (chain,)
    particle]), the wall seconds and the number of right-hand-side evaluations."""
    q0, v0 = np.asarray(q0, float), np.asarray(v0, float)
    shape, calls = q0.shape, [0]
    chains, n = (1,) + shape if q0.ndim == 1 else shape
    start = time.perf_counter()
    solver = ode(_equations(omega, chains, n, calls)).set_integrator("dop853", rtol=rtol, atol=atol, nsteps=10**9)
    solver.set_initial_value(np.concatenate([q0.ravel(), v0.ravel()]), 0.0)
    out = np.empty((len(times), 2 * chains * n))
    for k, t in enumerate(times):
        out[k] = solver.integrate(t)
        if not solver.successful():
            raise RuntimeError(f"DOP853 failed at t = {t:g} (omega = {omega:g}, rtol = {rtol:g})")
    half = chains * n
    return (out[:, :half].reshape((-1,) + shape), out[:, half:].reshape((-1,) + shape), time.perf_counter() - start,
            calls[0])


def reference(q0, v0, omega, times, rtol=1e-12, check_rtol=1e-10, perturbation=None):
    """The FPU chain from (q0, v0) at `times` by DOP853 at rtol, and again at check_rtol for its own error.

    perturbation: also integrate the chain from q0 + perturbation, together with the reference and so with the same
    steps, which keeps the solver's own error out of their difference (q_perturbed).
    Returns dict(q, v, q_check, v_check[, q_perturbed]: arrays [time, particle]; rtol, check_rtol, method, wall_s
    and check_wall_s, rhs_evaluations)."""
    times = np.asarray(times, float)
    if perturbation is None:
        q, v, wall, calls = dop853(q0, v0, omega, times, rtol)
    else:
        q, v, wall, calls = dop853([q0, q0 + perturbation], [v0, v0], omega, times, rtol)
        q, v, q_perturbed = q[:, 0], v[:, 0], q[:, 1]
    q_check, v_check, check_wall, _ = dop853(q0, v0, omega, times, check_rtol)
    out = {"q": q, "v": v, "q_check": q_check, "v_check": v_check, "rtol": rtol, "check_rtol": check_rtol,
           "method": f"SciPy DOP853 (scipy.integrate.ode), rtol {rtol:g}, atol 1e-15; check run at rtol "
                     f"{check_rtol:g}",
           "wall_s": wall, "check_wall_s": check_wall, "rhs_evaluations": calls}
    if perturbation is not None:
        out["q_perturbed"] = q_perturbed
    return out

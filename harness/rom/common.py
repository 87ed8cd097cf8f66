"""Pieces shared by the reduced models: state checks, the velocity rate of
eq. 2.19, and the Python driver that runs any model in chunks.

Status codes of the compiled loops: 0 ok, 1 non-finite, 2 runaway (|a| above
the bound).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ..errors import SimulationError
from ..progress import progress_bar

@njit(cache=True, nogil=True)
def _check(av, ar, bound):
    for i in range(av.size):
        if not np.isfinite(av[i]):
            return 1
        if abs(av[i]) > bound:
            return 2
    for i in range(ar.size):
        if not np.isfinite(ar[i]):
            return 1
        if abs(ar[i]) > bound:
            return 2
    return 0


@njit(cache=True, nogil=True)
def _velocity_rate(av, ar, K, b, D, has_d, F, dv):
    kv, kr = K.shape
    for p in range(kv):
        s = b[p] + F[p]
        for q in range(kr):
            s -= K[p, q] * ar[q]
        if has_d:
            for q in range(kv):
                s -= D[p, q] * av[q]
        dv[p] = s


MODELS = ("original", "linearized", "frozen")
METHODS = {"euler": 0, "symplectic": 1, "rk4": 2}
RUNAWAY_FACTOR = 1e6


def runaway_bound(ops):
    """|a| above this is a runaway: 10⁶ x the largest initial reduced coordinate."""
    return RUNAWAY_FACTOR * max(np.max(np.abs(ops.a_v0)), np.max(np.abs(ops.a_rho0)), 1e-300)


@dataclass
class ROMResult:
    """Samples of a reduced-model run.

    t (M,) [s], steps (M,), a_v (M, k_v), a_rho (M, k_rho) reduced coordinates,
    wall_time: online time of the loop [s], offline: dict of offline times [s].
    """

    model: str
    t: np.ndarray
    steps: np.ndarray
    a_v: np.ndarray
    a_rho: np.ndarray
    ops: object
    wall_time: float
    offline: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    @property
    def v(self):
        """Reconstructed velocity U^v a^v at the particles, (M, N) [m s^-1]."""
        return self.a_v @ self.ops.U_v.T

    @property
    def rho(self):
        """Reconstructed density U^ρ a^ρ at the particles, (M, N) [kg m^-3]."""
        return self.a_rho @ self.ops.U_rho.T


def run_reduced(model, ops, problem, *, n_steps, dt, integrator="euler", sample_steps=None, every=1,
                n_freeze=10, refresh="tensor", force=None, bound=None, progress=False, state=None):
    """Run a reduced model from step 0 to ``n_steps``.

    Parameters
    ----------
    model : {"original", "linearized", "frozen"}
    ops : ReducedOperators
    problem : SPHProblem
        The full problem the operators come from (fields and G).
    integrator : {"euler", "symplectic", "rk4"}
        RK4 is not defined for frozen coefficients.
    sample_steps : array_like of int, optional
        Steps to store (default every ``every`` steps and the last).
    n_freeze : int
        Refresh period of the frozen coefficients (frozen model only).
    refresh : {"tensor", "direct"}
        The exact O(k⁴)-type refresh or the O(N k²) reference path.
    force : callable, optional
        f(t) [m s^-2], vectorised; default the scene's.
    state : (a_v, a_rho), optional
        Initial reduced coordinates (default the projections of v0, ρ0).

    Raises
    ------
    SimulationError
        Non-finite or runaway reduced state, naming the step and time.
    """
    from .frozen import frozen_advance
    from .galerkin import galerkin_advance
    from .operators import pair_index

    if model not in MODELS:
        raise ValueError(model)
    method = METHODS[integrator]
    if model == "frozen" and method == 2:
        raise ValueError("frozen coefficients are defined for euler and symplectic only")
    if sample_steps is None:
        sample_steps = np.union1d(np.arange(0, n_steps + 1, every), [n_steps])
    sample_steps = np.unique(np.asarray(sample_steps, dtype=np.int64))
    force = force or problem.scene.force
    av = np.array(ops.a_v0 if state is None else state[0], dtype=float)
    ar = np.array(ops.a_rho0 if state is None else state[1], dtype=float)
    out_av = np.empty((sample_steps.size, ops.k_v))
    out_ar = np.empty((sample_steps.size, ops.k_rho))
    bound = runaway_bound(ops) if bound is None else bound
    has_d = ops.D is not None
    has_f = ops.p is not None
    D = ops.D if has_d else np.zeros((1, 1))
    pv = ops.p if has_f else np.zeros(ops.k_v)
    nb = problem.neighbours
    if model == "frozen":
        if refresh == "tensor" and ops.T is None:
            raise ValueError("no refresh tensor (k too large); use refresh='direct'")
        T = ops.T if refresh == "tensor" else np.zeros((1, 1, 1))
        pairs = pair_index(ops.k_rho)
        M = np.zeros((ops.k_rho, ops.k_v))
        F = np.zeros(ops.k_v)

        def advance(n0, n1, g, ptr):
            return frozen_advance(method, av, ar, n0, n1, dt, np.ascontiguousarray(g[:, 0]), ops.K, ops.b, D, has_d, pv, has_f, T, pairs,
                                  refresh == "tensor", ops.U_rho, ops.GU_v, ops.inv_rho0, int(n_freeze), M, F,
                                  sample_steps, ptr, out_av, out_ar, bound)
    else:
        mcode = 0 if model == "original" else 1
        # the original model applies the scene's force through the full right-hand side
        flags = problem.flags(problem.terms["force_profile"] if model == "original" else has_f)
        packed = [problem.packed(name) for name in ("rho0", "c", "d", "profile")]
        Uv = np.ascontiguousarray(ops.U_v)
        Ur = np.ascontiguousarray(ops.U_rho)

        def advance(n0, n1, g, ptr):
            return galerkin_advance(mcode, method, av, ar, n0, n1, dt, g, ops.K, ops.b, D, has_d, pv, has_f,
                                    ops.GU_v, ops.inv_rho0, Uv, Ur, nb.index, nb.weight, *packed, flags,
                                    sample_steps, ptr, out_av, out_ar, bound)

    def forces(n0, n1):
        g = np.zeros((n1 - n0, 3))
        if has_f or (model == "original" and problem.terms["force_profile"]):
            tn = np.arange(n0, n1) * dt
            g[:, 0] = force(tn)
            if method == 2:
                g[:, 1] = force(tn + 0.5 * dt)
                g[:, 2] = force(tn + dt)
        return g

    cost = ops.k_v * ops.k_rho if model == "frozen" else problem.n * (ops.k_v + ops.k_rho)
    chunk = max(1, min(n_steps, int(5e7 // max(cost, 1))))
    advance(0, 0, np.zeros((0, 3)), 0)          # load the compiled loop before the clock starts
    ptr, wall, n0 = 0, 0.0, 0
    with progress_bar(total=n_steps, desc=f"rom {model}", unit="step", enabled=progress) as bar:
        while n0 < n_steps:
            n1 = min(n_steps, n0 + chunk)
            g = forces(n0, n1)
            t0 = time.perf_counter()
            status, ptr, bad = advance(n0, n1, g, ptr)
            wall += time.perf_counter() - t0
            if status != 0:
                what = "non-finite" if status == 1 else f"runaway (|a| > {bound:.3g})"
                raise SimulationError(f"{model} reduced state became {what} by step {bad} (t = {bad * dt:.6g} s)",
                                      step=bad, time=bad * dt)
            bar.update(n1 - n0)
            n0 = n1
    settings = {"model": model, "integrator": integrator, "dt": dt, "k_v": ops.k_v, "k_rho": ops.k_rho}
    if model == "frozen":
        settings.update(n_freeze=int(n_freeze), refresh=refresh)
    return ROMResult(model=model, t=sample_steps * dt, steps=sample_steps, a_v=out_av, a_rho=out_ar, ops=ops,
                     wall_time=wall, offline=dict(ops.timings), settings=settings)

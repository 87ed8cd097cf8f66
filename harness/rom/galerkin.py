"""The compiled rates and time loop of the two Galerkin models, and their Python driver.

The original POD-MOR (:mod:`.original`) and the density-linearised one
(:mod:`.linearized`) both need the full state at every rate evaluation, so they
share Euler, symplectic Euler (ρ then v) and RK4; ``ops.full_rhs`` selects the
rate: the full SPH right-hand side at the reconstruction (original) or eqs.
2.19-2.20 with ρ² from the reconstruction (linearised).
"""

import numpy as np
from numba import njit

from ..sph.loops import rates
from .loops import GalerkinOperators, _check, _velocity_rate
from .result import ReducedResult
from .stepping import (drive, energy_guard, force_table, method_code, runaway_bound, sample_blocks, sample_grid,
                       start_arrays)

INTEGRATORS = ("euler", "symplectic", "rk4")


@njit(cache=True, nogil=True)
def _original_rates(av, ar, g, ops, dv, dr, v, rho, fv, fr, tmp):
    """Galerkin projection (eq. 2.16, Φ = U) of eqs. 2.10-2.11 at v = U^v a^v, ρ = U^ρ a^ρ: O(N k)."""
    Uv, Ur = ops.U_v, ops.U_rho
    n, kv = Uv.shape
    kr = Ur.shape[1]
    for i in range(n):
        s = 0.0
        for q in range(kv):
            s += Uv[i, q] * av[q]
        v[i] = s
        s = 0.0
        for q in range(kr):
            s += Ur[i, q] * ar[q]
        rho[i] = s
    rates(v, rho, g, ops.index, ops.weight, ops.rho0, ops.c, ops.d, ops.profile, ops.flags,   # eqs. 2.10-2.11
          fv, fr, tmp)
    for p in range(kv):                                                          # eq. 2.16, Φ = U
        s = 0.0
        for i in range(n):
            s += Uv[i, p] * fv[i]
        dv[p] = s
    for p in range(kr):
        s = 0.0
        for i in range(n):
            s += Ur[i, p] * fr[i]
        dr[p] = s


@njit(cache=True, nogil=True)
def _linearized_rates(av, ar, g, ops, F, dv, dr, rho, w):
    """Eq. 2.19 with the precomputed K, b, D̂, p̂; eq. 2.20 with ρ² from ρ = U^ρ a^ρ: O(N k)."""
    K, Ur, GUv, inv_rho0 = ops.K, ops.U_rho, ops.GU_v, ops.inv_rho0
    kv, kr = K.shape
    n = Ur.shape[0]
    for p in range(kv):
        F[p] = ops.p[p] * g if ops.has_f else 0.0
    _velocity_rate(av, ar, K, ops.b, ops.D, ops.has_d, F, dv)       # eq. 2.19
    for i in range(n):                                              # eq. 2.20, ρ² from U^ρ a^ρ
        r = 0.0
        for a in range(kr):
            r += Ur[i, a] * ar[a]
        s = 0.0
        for q in range(kv):
            s += GUv[i, q] * av[q]
        w[i] = r * r * inv_rho0[i] * s
    for p in range(kr):
        s = 0.0
        for i in range(n):
            s -= Ur[i, p] * w[i]
        dr[p] = s


@njit(cache=True, nogil=True)
def galerkin_advance(method, av, ar, n0, n1, dt, g, ops, sample_steps, ptr, out_av, out_ar, bound):
    """Original (``ops.full_rhs``) or linearised POD-MOR from step n0 to n1.

    method 0 Euler, 1 symplectic Euler (ρ then v), 2 RK4; g[row] holds f at
    the stage times t_n, t_n + dt/2, t_n + dt; ``ops`` a
    :data:`~sphrom.rom.loops.GalerkinOperators`.  Returns (status, ptr, step).
    """
    full = ops.full_rhs
    n = ops.U_v.shape[0]
    kv, kr = av.size, ar.size
    dv = np.empty(kv); dr = np.empty(kr); F = np.empty(kv)
    v = np.empty(n); rho = np.empty(n); fv = np.empty(n); fr = np.empty(n); tmp = np.empty(n)
    k1v = np.empty(kv); k1r = np.empty(kr); k2v = np.empty(kv); k2r = np.empty(kr)
    k3v = np.empty(kv); k3r = np.empty(kr); tv = np.empty(kv); tr = np.empty(kr)

    for step in range(n0, n1):
        if ptr < sample_steps.size and sample_steps[ptr] == step:
            out_av[ptr, :] = av
            out_ar[ptr, :] = ar
            ptr += 1
        row = step - n0
        if method == 2:
            for stage in range(4):
                if stage == 0:
                    tv[:] = av; tr[:] = ar; gs = g[row, 0]
                elif stage == 1:
                    for p in range(kv): tv[p] = av[p] + 0.5 * dt * k1v[p]
                    for p in range(kr): tr[p] = ar[p] + 0.5 * dt * k1r[p]
                    gs = g[row, 1]
                elif stage == 2:
                    for p in range(kv): tv[p] = av[p] + 0.5 * dt * k2v[p]
                    for p in range(kr): tr[p] = ar[p] + 0.5 * dt * k2r[p]
                    gs = g[row, 1]
                else:
                    for p in range(kv): tv[p] = av[p] + dt * k3v[p]
                    for p in range(kr): tr[p] = ar[p] + dt * k3r[p]
                    gs = g[row, 2]
                if full:
                    _original_rates(tv, tr, gs, ops, dv, dr, v, rho, fv, fr, tmp)
                else:
                    _linearized_rates(tv, tr, gs, ops, F, dv, dr, rho, tmp)
                if stage == 0:
                    k1v[:] = dv; k1r[:] = dr
                elif stage == 1:
                    k2v[:] = dv; k2r[:] = dr
                elif stage == 2:
                    k3v[:] = dv; k3r[:] = dr
            for p in range(kv):
                av[p] += dt / 6.0 * (k1v[p] + 2.0 * k2v[p] + 2.0 * k3v[p] + dv[p])
            for p in range(kr):
                ar[p] += dt / 6.0 * (k1r[p] + 2.0 * k2r[p] + 2.0 * k3r[p] + dr[p])
        else:
            gs = g[row, 0]
            if full:
                _original_rates(av, ar, gs, ops, dv, dr, v, rho, fv, fr, tmp)
            else:
                _linearized_rates(av, ar, gs, ops, F, dv, dr, rho, tmp)
            if method == 0:
                for p in range(kv):
                    av[p] += dt * dv[p]
                for p in range(kr):
                    ar[p] += dt * dr[p]
            else:
                for p in range(kr):
                    ar[p] += dt * dr[p]
                if full:
                    _original_rates(av, ar, gs, ops, dv, dr, v, rho, fv, fr, tmp)
                else:
                    _linearized_rates(av, ar, gs, ops, F, dv, dr, rho, tmp)
                for p in range(kv):
                    av[p] += dt * dv[p]
        if (step + 1 - n0) % 64 == 0 or step + 1 == n1:
            status = _check(av, ar, bound)
            if status != 0:
                return status, ptr, step + 1
    if ptr < sample_steps.size and sample_steps[ptr] == n1:
        out_av[ptr, :] = av
        out_ar[ptr, :] = ar
        ptr += 1
    return 0, ptr, n1


def loop_operators(ops, problem, full_rhs):
    """The :data:`~sphrom.rom.loops.GalerkinOperators` of one run.

    The original model (``full_rhs``) applies the scene's force through the
    full right-hand side (the profile, eqs. 2.10-2.11); the linearised one
    through the input row p̂ of the operators.
    """
    has_d = ops.D is not None
    has_f = ops.p is not None
    nb = problem.neighbours
    rho0, c, d, profile = (problem.packed(name) for name in ("rho0", "c", "d", "profile"))
    return GalerkinOperators(
        full_rhs=bool(full_rhs), K=ops.K, b=ops.b, D=ops.D if has_d else np.zeros((1, 1)), has_d=has_d,
        p=ops.p if has_f else np.zeros(ops.k_v), has_f=has_f, GU_v=ops.GU_v, inv_rho0=ops.inv_rho0,
        U_v=np.ascontiguousarray(ops.U_v), U_rho=np.ascontiguousarray(ops.U_rho), index=nb.index, weight=nb.weight,
        rho0=rho0, c=c, d=d, profile=profile,
        flags=problem.flags(problem.terms["force_profile"] if full_rhs else has_f))


def run_galerkin(name, full_rhs, ops, problem, *, dt, n_steps, sample_steps, every, force, state,
                 initial_state_scale, bound, progress, options):
    """Run the original (``full_rhs``) or the linearised model (the shared arguments of :mod:`sphrom.rom.model`;
    ``options`` a :class:`~sphrom.rom.model.GalerkinOptions`)."""
    integrator = options.integrator or INTEGRATORS[0]
    method = method_code(integrator, INTEGRATORS, f"{name} POD-MOR integrators")
    steps = sample_grid(n_steps, sample_steps, every)
    force = force or problem.scene.force
    av, ar, out_z = start_arrays(ops, state, steps.size, initial_state_scale)
    out_av, out_ar = sample_blocks(out_z, ops.k_v)
    bound = runaway_bound(ops) if bound is None else bound
    loop = loop_operators(ops, problem, full_rhs)
    force_active = loop.has_f or (bool(full_rhs) and problem.terms["force_profile"])

    def advance(n0, n1, g, ptr):
        return galerkin_advance(method, av, ar, n0, n1, dt, g, loop, steps, ptr, out_av, out_ar, bound)

    wall = drive(name, advance, lambda n0, n1: force_table(force, force_active, method, n0, n1, dt),
                 n_steps=n_steps, dt=dt, cost=problem.n * (ops.k_v + ops.k_rho), bound=bound, progress=progress,
                 guard=energy_guard(ops, problem, av, ar, dt=dt, name=name, integrator=integrator))
    settings = {"model": name, "integrator": integrator, "dt": dt, "k_v": ops.k_v, "k_rho": ops.k_rho}
    return ReducedResult(model=name, t=steps * dt, steps=steps, z=out_z, ops=ops, wall_time=wall,
                         offline=dict(ops.timings), settings=settings)

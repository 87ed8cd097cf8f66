"""Accelerated POD-MOR with frozen coefficients (eqs. 2.19-2.24).

M(a^ρ) = U^ρᵀ diag(ρ²/ρ0) G U^v (eq. 2.23 projected) and the force
projection p̂ f(t) are refreshed every ``n_freeze`` steps; between refreshes a
step costs O(k²).  The refresh uses the exact tensor of
:mod:`sphrom.rom.operators` (O(k_ρ³ k_v / 2), no N) or, as the reference, the
straightforward O(N k²) product.

The step is written with plain loops in a fixed order, which the C model core
(fmu_src/rom_frozen.c) repeats operation for operation:

    refresh (step % n_freeze == 0):
        M[p][q] = 0;  for each pair (a <= b): s = ar[a]*ar[b]; M[p][q] += s*T[pair][p][q]
        F[p] = pv[p]*g;  then per port j (ascending): F[p] += Bp[j][p]*u_j,  u_j = F_port_j / area
    dr[p] = 0;            dr[p] -= M[p][q]*av[q]          (q ascending)
    dv[p] = b[p] + F[p];  dv[p] -= K[p][q]*ar[q];  dv[p] -= D[p][q]*av[q]
    euler:      av += h*dv;  ar += h*dr              (dv, dr from the old state)
    symplectic: ar += h*dr, then dv with the new ar, av += h*dv

b of eq. 2.19 is a build option (:func:`sphrom.rom.operators.build_operators`): ``b="rest"``, b = K a^ρ_rest
(:func:`sphrom.rom.operators.rest_b`, the projected rest state an equilibrium), is the registry's default and
the FMU's model; ``b="paper"``, eq. 2.22's b, is the model's ``paper_build``.  Which each entry point uses:

    rest   ``get_model("frozen").build``, ``sphrom fmu`` (and every FMU: ``sphrom cosim``, ``sphrom sweep``,
           the benchmarks' FMU rows, the stress maps' FMU columns), the envelope bench
    paper  ``sphrom rom --model frozen`` (``--b rest`` for the FMU's), the validation report, the mode sweeps
           (``sphrom modes``), the benchmarks' Python rows (methods, scaling, skip, stress, reduced stability,
           linear models' trade-off): the reproduced figures stay the paper's model bit for bit
    both   ``python -m sphrom.bench.rest`` (the FMU of each, through the option)

The projection is a build option too (``inner``, :func:`sphrom.rom.operators.build_operators`): the paper's
Euclidean Galerkin projection (eq. 2.16, Φ = U) without ports, the energy inner products with ports (a passive
port map on every scene, :mod:`sphrom.rom.passivity`); the step above is the same, the weights are in the numbers.
"""

import numpy as np
from numba import njit

from .loops import FrozenOperators, _check, _velocity_rate
from .model import FrozenOptions, ReducedModel
from .operators import build_from_basis, pair_index, truncate_operators
from .result import ReducedResult
from .stepping import (drive, energy_guard, force_table, method_code, port_work, runaway_bound, sample_blocks,
                       sample_grid, start_arrays)


@njit(cache=True, nogil=True)
def _density_rate_frozen(av, M, dr):
    kr, kv = M.shape
    for p in range(kr):
        s = 0.0
        for q in range(kv):
            s -= M[p, q] * av[q]
        dr[p] = s


@njit(cache=True, nogil=True)
def refresh_tensor_path(ar, T, pairs, M):
    """M = Σ_{a<=b} ar[a] ar[b] T[pair] (exact, no N)."""
    kr, kv = M.shape
    for p in range(kr):
        for q in range(kv):
            M[p, q] = 0.0
    for k in range(pairs.shape[0]):
        s = ar[pairs[k, 0]] * ar[pairs[k, 1]]
        for p in range(kr):
            for q in range(kv):
                M[p, q] += s * T[k, p, q]


@njit(cache=True, nogil=True)
def refresh_direct_path(ar, Ur, GUv, inv_rho0, M):
    """M = U^ρᵀ diag(ρ²/ρ0) G U^v with ρ = U^ρ a^ρ: the O(N k²) reference path."""
    n, kr = Ur.shape
    kv = GUv.shape[1]
    for p in range(kr):
        for q in range(kv):
            M[p, q] = 0.0
    for i in range(n):
        rho = 0.0
        for a in range(kr):
            rho += Ur[i, a] * ar[a]
        w = rho * rho * inv_rho0[i]
        for p in range(kr):
            up = w * Ur[i, p]
            for q in range(kv):
                M[p, q] += up * GUv[i, q]


@njit(cache=True, nogil=True)
def frozen_advance(method, av, ar, M, F, n0, n1, dt, g, ops, sample_steps, ptr, out_av, out_ar, bound, Bp=None,
                   gp=None):
    """Frozen-coefficient model from step n0 to n1 (method 0 Euler, 1 symplectic).

    ``av``, ``ar`` are the reduced state and ``M``, ``F`` the frozen
    coefficients, carried between calls; ``g[row]`` is f at step n0 + row;
    ``ops`` a :data:`~sphrom.rom.loops.FrozenOperators`.  States at the
    ``sample_steps`` from ``ptr`` on go to ``out_av``, ``out_ar``.  Returns
    (status, ptr, step).  Ports (:mod:`sphrom.sph.ports`): ``Bp`` (P, k_v) the
    input rows, ``gp[row, j]`` the port force F_j / A at step n0 + row [N m^-2],
    frozen with f at each refresh.
    """
    K = ops.K
    kv, kr = K.shape
    dv = np.empty(kv)
    dr = np.empty(kr)
    for step in range(n0, n1):
        if ptr < sample_steps.size and sample_steps[ptr] == step:
            out_av[ptr, :] = av
            out_ar[ptr, :] = ar
            ptr += 1
        if step % ops.n_freeze == 0:
            if ops.use_tensor:
                refresh_tensor_path(ar, ops.T, ops.pairs, M)
            else:
                refresh_direct_path(ar, ops.U_rho, ops.GU_v, ops.inv_rho0, M)
            for p in range(kv):
                F[p] = ops.p[p] * g[step - n0] if ops.has_f else 0.0
            if Bp is not None:
                for j in range(Bp.shape[0]):
                    u = gp[step - n0, j]
                    for p in range(kv):
                        F[p] += Bp[j, p] * u
        _density_rate_frozen(av, M, dr)
        if method == 0:
            _velocity_rate(av, ar, K, ops.b, ops.D, ops.has_d, F, dv)
            for p in range(kv):
                av[p] += dt * dv[p]
            for p in range(kr):
                ar[p] += dt * dr[p]
        else:
            for p in range(kr):
                ar[p] += dt * dr[p]
            _velocity_rate(av, ar, K, ops.b, ops.D, ops.has_d, F, dv)
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


def loop_operators(K, b, D, p, n_freeze, *, T=None, U_rho=None, GU_v=None, inv_rho0=None, refresh="tensor"):
    """The :data:`~sphrom.rom.loops.FrozenOperators` of one run (built once per run).

    ``D`` or ``p`` None: no damping / no input (a dummy array in the tuple).
    ``refresh="tensor"`` needs ``T``; ``"direct"`` needs ``U_rho``, ``GU_v``, ``inv_rho0``.
    """
    if refresh not in ("tensor", "direct"):
        raise ValueError(f"refresh {refresh!r} (allowed: tensor, direct)")
    tensor = refresh == "tensor"
    if tensor and T is None:
        raise ValueError("no refresh tensor (k too large); use refresh='direct'")
    kv, kr = K.shape
    dummy2 = np.zeros((1, 1))
    return FrozenOperators(
        K=np.ascontiguousarray(K), b=np.ascontiguousarray(b), D=dummy2 if D is None else np.ascontiguousarray(D),
        has_d=D is not None, p=np.zeros(kv) if p is None else np.ascontiguousarray(p), has_f=p is not None,
        T=np.ascontiguousarray(T) if tensor else np.zeros((1, 1, 1)), pairs=pair_index(kr), use_tensor=tensor,
        U_rho=dummy2 if tensor else np.ascontiguousarray(U_rho),
        GU_v=dummy2 if tensor else np.ascontiguousarray(GU_v),
        inv_rho0=np.zeros(1) if tensor else np.ascontiguousarray(inv_rho0), n_freeze=int(n_freeze))


INTEGRATORS = ("euler", "symplectic")


def run(ops, problem, *, dt, n_steps, sample_steps, every, force, state, initial_state_scale, bound, progress,
        options, port_forces=None, area=1.0):
    """Run the frozen-coefficient model (the shared arguments of :mod:`sphrom.rom.model`;
    ``options`` a :class:`~sphrom.rom.model.FrozenOptions`).

    ``ops`` are :class:`~sphrom.rom.operators.ReducedOperators`; ``options.refresh``
    ``tensor`` (exact, no N) or ``direct`` (the O(N k²) reference path).  ``port_forces(t) -> (len(t), P)`` [N]
    at the step times (operators built with ports), divided by the cross-section ``area`` [m^2]; like f they
    are sampled at each refresh.
    """
    integrator = options.integrator or INTEGRATORS[0]
    n_freeze, refresh = options.n_freeze, options.refresh
    method = method_code(integrator, INTEGRATORS, "frozen coefficients")
    if port_forces is not None and ops.Bp is None:
        raise ValueError("port_forces: the operators have no ports (build them with ports=...)")
    steps = sample_grid(n_steps, sample_steps, every)
    force = force or problem.scene.force
    av, ar, out_z = start_arrays(ops, state, steps.size, initial_state_scale)
    out_av, out_ar = sample_blocks(out_z, ops.k_v)
    bound = runaway_bound(ops) if bound is None else bound
    loop = loop_operators(ops.K, ops.b, ops.D, ops.p, n_freeze, T=ops.T, U_rho=ops.U_rho, GU_v=ops.GU_v,
                          inv_rho0=ops.inv_rho0, refresh=refresh)
    M = np.zeros((ops.k_rho, ops.k_v))
    F = np.zeros(ops.k_v)

    def advance(n0, n1, g, ptr):
        if port_forces is None:
            return frozen_advance(method, av, ar, M, F, n0, n1, dt, np.ascontiguousarray(g[:, 0]), loop, steps, ptr,
                                  out_av, out_ar, bound)
        gp = np.asarray(port_forces(np.arange(n0, n1) * dt), float).reshape(n1 - n0, ops.Bp.shape[0]) / area
        return frozen_advance(method, av, ar, M, F, n0, n1, dt, np.ascontiguousarray(g[:, 0]), loop, steps, ptr,
                              out_av, out_ar, bound, ops.Bp, np.ascontiguousarray(gp))

    wall = drive(MODEL.name, advance, lambda n0, n1: force_table(force, loop.has_f, method, n0, n1, dt),
                 n_steps=n_steps, dt=dt, cost=ops.k_v * ops.k_rho, bound=bound, progress=progress,
                 guard=energy_guard(ops, problem, av, ar, dt=dt, name=MODEL.name, integrator=integrator,
                                    port_work=None if port_forces is None else
                                    port_work(problem, ops.ports, port_forces, dt, area)))
    settings = {"model": MODEL.name, "integrator": integrator, "dt": dt, "k_v": ops.k_v, "k_rho": ops.k_rho,
                "n_freeze": int(n_freeze), "refresh": refresh}
    return ReducedResult(model=MODEL.name, t=steps * dt, steps=steps, z=out_z, ops=ops, wall_time=wall,
                         offline=dict(ops.timings), settings=settings)


MODEL = ReducedModel(
    name="frozen",
    description="accelerated POD-MOR with frozen coefficients (eqs. 2.19-2.24): O(k²) per step between refreshes",
    title="Frozen-coefficient POD reduced model (Fang et al., eqs. 2.19-2.24)",
    linear=False, integrators=INTEGRATORS, basis_kind="density", ports=True,
    fmu_kind=1,                 # resources/model.bin kind 1 (sphrom.fmu.resources.MODEL_FROZEN)
    builder=build_from_basis, solver=run, truncate=truncate_operators, options_type=FrozenOptions,
    # the registry's frozen model is the FMU's: b about the projected rest density, so rest is an equilibrium;
    # the paper's eq. 2.22 b where the paper is reproduced
    build_defaults={"b": "rest"}, paper_build={"b": "paper", "inner": "euclid"})

"""Finite-element reference (scikit-fem): the displacement form of appendix A.

With u = z - x (eqs. A.1-A.3) the system is linear in u:

    ρ0 u_tt = (c u_x)_x - ρ0 d u_t + ρ0 p(x) f(t),   u(x,0) = 0,  u_t(x,0) = v0(x),
    v = u_t,   ρ = ρ0 / (1 + u_x)                                         (A.3)

Galerkin with P1 or P2 Lagrange elements on a uniform periodic mesh of N
elements gives M ü + C u̇ + K u = f(t) b with

    M = ∫ ρ0 φ_i φ_j,  K = ∫ c φ_i' φ_j',  C = ∫ ρ0 d φ_i φ_j,  b = ∫ ρ0 p φ_i,

assembled by scikit-fem on the interval mesh [0, L] with the coefficients
evaluated at the quadrature points, so that a jump of c at a node (x = L/2
for N even, eq. 3.11) is integrated exactly.  Periodicity is imposed by
identifying the dof at x = L with the one at x = 0 (a 0/1 matrix P,
M_per = Pᵀ M P); scikit-fem's own periodic ``MeshLine1DG`` would do the
same, but cannot locate points, which the output needs.

Time: Newmark's average-acceleration rule (the trapezoidal rule, second
order, unconditionally stable, no numerical damping),

    (M + Δt/2 C + Δt²/4 K) a_{n+1} = f_{n+1} b - C (v_n + Δt/2 a_n) - K (u_n + Δt v_n + Δt²/4 a_n),
    u_{n+1} = u_n + Δt v_n + Δt²/4 (a_n + a_{n+1}),   v_{n+1} = v_n + Δt/2 (a_n + a_{n+1}),

with the constant matrix factorised once (``scipy.sparse.linalg.splu``, in a
symmetric minimum-degree order), so a step is one back-substitution and two
sparse products.  v(0) is the
ρ0-weighted L² projection of v0, so ∫ ρ0 v is exact at t = 0 and kept to
round-off (1ᵀK = 0); ∫ ρ0/ρ = ∫ (1 + u_x) = L holds identically.

**Output.**  v is taken at the dofs (nodes, and element midpoints for P2: a
uniform grid of spacing h/order) and spline-interpolated.  The strain u_x is
taken where the element derivative superconverges: the element midpoints for
P1 and the two Gauss-Legendre points of each element for P2 (error
O(h^{k+1}) there, against O(h^k) elsewhere), then spline-interpolated and
ρ = ρ0(x)/(1 + u_x) formed at the output points.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu
from skfem import Basis, BilinearForm, ElementLineP1, ElementLineP2, LinearForm, MeshLine1, asm

from ..errors import FieldError, SimulationError
from ..progress import progress_bar
from ..scene import Scene
from .common import (NativeRun, Reference, check_dt, coefficient_breaks, force_active, output_points,
                     output_times, resolution_from, step_plan, to_output)

ELEMENTS = {1: ElementLineP1, 2: ElementLineP2}
DEFAULT_N = {1: 4096, 2: 256}        # elements: ~1e-5 relative at T = 10 on the smooth scenes
DEFAULT_DT = {1: 2.5e-4, 2: 1.25e-4}  # s: Newmark's phase error (ωΔt)²/12 <~ 1e-7 per radian at ω = 6
INTORDER = 10                        # quadrature order for the assembly (non-polynomial fields)


@BilinearForm
def _mass(u, w, p):
    return p["rho0"] * u * w


@BilinearForm
def _stiffness(u, w, p):
    return p["c"] * u.grad[0] * w.grad[0]


@BilinearForm
def _damping(u, w, p):
    return p["rho0"] * p["d"] * u * w


@LinearForm
def _load(w, p):
    return p["rho0"] * p["profile"] * w


@LinearForm
def _initial_momentum(w, p):
    return p["rho0"] * p["v0"] * w


@dataclass
class FEMSystem:
    """The periodic Galerkin system of one mesh.

    M, K, C : sparse (n, n)   mass [kg m^-2·m], stiffness, damping matrices
    b : ndarray (n,)          load per unit f(t)
    m0v0 : ndarray (n,)       ∫ ρ0 v0 φ_i
    x_dof : ndarray (n,)      position of each periodic dof [m]
    grad : sparse (q, n)      dof values -> u_x at the superconvergence points
    x_grad : ndarray (q,)     those points [m]
    w_grad : ndarray (q,)     quadrature weights at those points [m]
    """

    M: sp.csr_matrix
    K: sp.csr_matrix
    C: sp.csr_matrix | None
    b: np.ndarray | None
    m0v0: np.ndarray
    x_dof: np.ndarray
    grad: sp.csr_matrix
    x_grad: np.ndarray
    w_grad: np.ndarray
    order: int
    n_elements: int


def _periodic_fold(x_dof, L):
    """P (n_full, n_per): the dof at x = L is the dof at x = 0."""
    n_full = x_dof.size
    at_end = np.nonzero(np.isclose(x_dof, L, rtol=0, atol=1e-12 * L))[0]
    at_start = np.nonzero(np.isclose(x_dof, 0.0, rtol=0, atol=1e-12 * L))[0]
    target = np.arange(n_full)
    target[at_end] = at_start
    keep = np.setdiff1d(np.arange(n_full), at_end)
    new = -np.ones(n_full, dtype=np.int64)
    new[keep] = np.arange(keep.size)
    cols = new[target]
    return sp.csr_matrix((np.ones(n_full), (np.arange(n_full), cols)), shape=(n_full, keep.size)), keep


def assemble(scene: Scene, n_elements, order=1):
    """Assemble the periodic P1/P2 system of ``scene`` on N uniform elements.

    Returns
    -------
    FEMSystem
    """
    L = scene.L
    mesh = MeshLine1.init_tensor(np.linspace(0.0, L, n_elements + 1))
    element = ELEMENTS[order]()
    basis = Basis(mesh, element, intorder=INTORDER)
    xq = np.asarray(basis.global_coordinates())[0]      # (elements, quadrature points)
    fields = {name: scene.field(name, xq) for name in ("rho0", "c", "d", "profile", "v0")}
    P, keep = _periodic_fold(basis.doflocs[0], L)
    PT = P.T.tocsr()

    def fold(A):
        return (PT @ A @ P).tocsr()

    M = fold(asm(_mass, basis, rho0=fields["rho0"]))
    K = fold(asm(_stiffness, basis, c=fields["c"]))
    C = None
    if np.any(fields["d"] != 0):
        C = fold(asm(_damping, basis, rho0=fields["rho0"], d=fields["d"]))
    b = None
    if np.any(fields["profile"] != 0):
        b = PT @ asm(_load, basis, rho0=fields["rho0"], profile=fields["profile"])
    m0v0 = PT @ asm(_initial_momentum, basis, rho0=fields["rho0"], v0=fields["v0"])

    # u_x at the superconvergence points: midpoints (P1) / 2 Gauss points (P2)
    if order == 1:
        ref_pts, ref_w = np.array([[0.5]]), np.array([1.0])
    else:
        s = 0.5 / np.sqrt(3.0)
        ref_pts, ref_w = np.array([[0.5 - s, 0.5 + s]]), np.array([0.5, 0.5])
    gbasis = Basis(mesh, element, quadrature=(ref_pts, ref_w))
    xg = np.asarray(gbasis.global_coordinates())[0]     # (elements, points)
    n_el, n_pt = xg.shape
    rows, cols, vals = [], [], []
    row_index = np.arange(n_el * n_pt).reshape(n_el, n_pt)
    for i in range(gbasis.element_dofs.shape[0]):
        dphi = gbasis.basis[i][0].grad[0]                # (elements, points)
        for q in range(n_pt):
            rows.append(row_index[:, q])
            cols.append(gbasis.element_dofs[i])
            vals.append(dphi[:, q])
    G = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_el * n_pt, gbasis.N))
    G = (G @ P).tocsr()
    h = L / n_elements
    return FEMSystem(M=M, K=K, C=C, b=b, m0v0=m0v0, x_dof=basis.doflocs[0][keep], grad=G,
                     x_grad=xg.ravel(), w_grad=np.tile(ref_w * h, n_el), order=order, n_elements=n_elements)


def run(scene: Scene, resolution=None, dt=None, t=None, *, dx=None, order=1, progress=False):
    """March the Newmark scheme; samples on the FE dofs and superconvergence points.

    Parameters
    ----------
    scene : Scene
    resolution : int, optional
        Number of elements N (default DEFAULT_N[order]); or give ``dx`` [m].
    dt : float, optional
        Largest time step [s] (default DEFAULT_DT[order]); reduced so that the
        output times are steps.
    t : ndarray, optional
        Output times [s] (default the scene's SPH sample times).
    order : {1, 2}
        P1 or P2 elements.
    progress : bool
        Progress bar on long runs.

    Returns
    -------
    NativeRun
    """
    if order not in ELEMENTS:
        raise FieldError("order", f"{order!r} is out of range (allowed: 1 or 2)")
    n = resolution_from(scene, resolution, dx, DEFAULT_N[order])
    t_out = output_times(scene, t)
    T = float(t_out[-1])
    dt_req = DEFAULT_DT[order] if dt is None else check_dt(dt, T if T > 0 else np.inf)
    dt_used, sample_steps = step_plan(t_out, dt_req)
    n_steps = int(sample_steps[-1])
    sys_ = assemble(scene, n, order)
    M, K, C, b = sys_.M, sys_.K, sys_.C, sys_.b
    forcing = b is not None and force_active(scene, max(T, dt_used))
    A = M + (0.25 * dt_used**2) * K
    if C is not None:
        A = A + (0.5 * dt_used) * C
    # A and M are symmetric: a symmetric fill-reducing order keeps a solve at ~10 ns per dof
    lu = splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A")
    lu_m = splu(M.tocsc(), permc_spec="MMD_AT_PLUS_A")
    u = np.zeros(M.shape[0])
    v = lu_m.solve(sys_.m0v0)                            # ρ0-weighted L² projection of v0
    f_steps = scene.force(np.arange(n_steps + 1) * dt_used) if forcing else None
    rhs0 = -(K @ u)
    if C is not None:
        rhs0 -= C @ v
    if forcing:
        rhs0 += f_steps[0] * b
    a = lu_m.solve(rhs0)
    out_v = np.empty((sample_steps.size, u.size))
    out_u = np.empty((sample_steps.size, u.size))
    ptr = 0
    while ptr < sample_steps.size and sample_steps[ptr] == 0:
        out_v[ptr], out_u[ptr] = v, u
        ptr += 1
    h2 = 0.25 * dt_used**2
    hdt = 0.5 * dt_used
    wall = 0.0
    t0 = _time.perf_counter()
    with progress_bar(total=n_steps, desc=f"skfem P{order} {scene.name}", unit="step", enabled=progress) as bar:
        for step in range(n_steps):
            u_pred = u + dt_used * v + h2 * a
            rhs = -(K @ u_pred)
            if C is not None:
                rhs -= C @ (v + hdt * a)
            if forcing:
                rhs += f_steps[step + 1] * b
            a_new = lu.solve(rhs)
            u = u_pred + h2 * a_new
            v = v + hdt * (a + a_new)
            a = a_new
            while ptr < sample_steps.size and sample_steps[ptr] == step + 1:
                out_v[ptr], out_u[ptr] = v, u
                ptr += 1
            if (step & 1023) == 1023:
                if not np.all(np.isfinite(v)):
                    raise SimulationError(f"skfem state became non-finite by step {step + 1} "
                                          f"(t = {(step + 1) * dt_used:.6g} s)", step=step + 1,
                                          time=(step + 1) * dt_used)
                bar.update(1024)
        bar.update(n_steps % 1024)
    wall = _time.perf_counter() - t0
    order_x = np.argsort(sys_.x_dof)
    order_g = np.argsort(sys_.x_grad)
    strain = (sys_.grad @ out_u.T).T                    # u_x = J - 1 (A.9)
    if np.any(1.0 + strain <= 0):
        raise SimulationError("skfem: the deformation folded (1 + u_x <= 0): the displacement is too large")
    x_g = sys_.x_grad[order_g]
    settings = {"method": f"P{order} Galerkin on the displacement form (A.1-A.3) + Newmark average acceleration",
                "order": order, "resolution": n, "dx": scene.L / n, "dofs": u.size, "dt": dt_used,
                "dt_requested": dt_req, "steps": n_steps,
                "strain_points": "element midpoints" if order == 1 else "2 Gauss-Legendre points per element"}
    return NativeRun(t=sample_steps * dt_used, x_v=sys_.x_dof[order_x], v=out_v[:, order_x], x_j=x_g,
                     j=strain[:, order_g], rho0_j=scene.field("rho0", x_g),
                     momentum_weights=np.asarray(M.sum(axis=0)).ravel()[order_x],
                     length_weights=sys_.w_grad[order_g], steps=sample_steps, wall_time=wall, settings=settings)


def solve(scene: Scene, resolution=None, dt=None, x=None, t=None, *, dx=None, order=1, progress=False):
    """The finite-element reference at the output points and times.

    Parameters
    ----------
    scene : Scene
    resolution, dx, dt, t, order, progress
        See :func:`run`.
    x : ndarray, optional
        Output Lagrangian positions [m] (default the scene's SPH particles).

    Returns
    -------
    Reference
        v (M, N_out) [m s^-1], rho (M, N_out) [kg m^-3], settings.
    """
    x_out = output_points(scene, x)
    native = run(scene, resolution, dt, t, dx=dx, order=order, progress=progress)
    breaks = coefficient_breaks(scene)
    v, rho = to_output(native, scene, x_out, breaks)
    settings = {**native.settings, "interpolation": "cubic spline, piecewise between jumps",
                "breaks": ",".join(f"{b:g}" for b in breaks) or "none", "wall_time": native.wall_time}
    return Reference(v, rho, settings)

"""Beyond the paper: balanced reduced models of the full linear SPH, with certified error bounds.

The full SPH in the specific volume is the LTI system of
:mod:`sphrom.rom.lti` (ẋ = (J - R) x + B u, y = C x, energy coordinates,
inputs: the force f and the initial-state excitation).  Two reductions:

``bt`` - square-root balanced truncation (damped scenes, d > 0 everywhere).
    The decoupled null modes of A (``LTI.null``) are moved to -γ first
    (same transfer function), so A is asymptotically stable; then the
    Gramians P, Q of the weighted system (A P + P Aᵀ + B Bᵀ = 0,
    Aᵀ Q + Q A + Cᵀ C = 0, scipy's Bartels-Stewart solver), their square-root
    factors, the SVD L_Qᵀ L_P = Z Σ Yᵀ, V = L_P Y_r Σ_r^-½, W = L_Q Z_r Σ_r^-½,
    Ar = Wᵀ A V, Br = Wᵀ B, Cr = C V.  Stable, with the bound
    ‖G - G_r‖_H∞ <= 2 Σ_{i>r} σ_i for the weighted system.

``galerkin`` - structure-preserving projection (any scene; the default when
    d = 0 somewhere, where A has poles on the imaginary axis and BT does not
    apply).  Gramians of the shifted system A - σI, σ = 1/T, the BT trial
    space V_BT above (the dominant right eigenspace of P_σ Q_σ), orthonormalised
    to V, and the Galerkin projection Ar = Vᵀ J V - Vᵀ R V in the energy
    coordinates (W = V; pyMOR's pH-preserving projection with Q = I).  Vᵀ J V
    is skew and Vᵀ R V symmetric >= 0, so the reduced energy ½|x_r|² never
    grows and is conserved exactly when d = f = 0: Ar is skew to the last
    bit (its skew part is taken explicitly).  Shifted BT itself (``bt_shifted``:
    BT of A - σI, shifted back) is kept for comparison only: its reduced
    poles may lie right of the axis (tenmode, r = 24: max Re λ = 5.6e-2).

Why not pyMOR's port-Hamiltonian reductors: the outputs here are probe
values, not the port-Hamiltonian's collocated output Bᵀx, so the
input-output system is not passive and PRBT and pH-IRKA do not apply; the
Galerkin projection above is pyMOR's ``PHLTIPGReductor`` (``ph_preserving``,
Q = I) with a Gramian-based V.

Certified error bounds (:func:`error_bounds`) for any Galerkin or
Petrov-Galerkin reduced model of the same LTI system (``balanced`` and the
exact POD model, :func:`reduced_from_exact`), on the horizon [0, T]:

force_error_bound[j] [s]
    ‖y_j - y_full,j‖_L2(0,T) <= bound_j ‖f‖_L2(0,T) from rest, for every f.
    bound_j = e^{σT} ‖G̃_j - G̃_r,j‖_H∞ with G̃ the force-to-probe-j transfer
    functions of the shifted systems A - σI, Ar - σI: with ỹ = e^{-σt} y and
    f̃ = e^{-σt} f, ỹ is the shifted system's response to f̃, so
    ‖y_err‖ <= e^{σT} ‖ỹ_err‖ <= e^{σT} ‖G̃_err‖ ‖f̃‖ <= e^{σT} ‖G̃_err‖ ‖f‖.
    σ = 0 when the error system is asymptotically stable with decay rate at
    least 0.1/T (damped scenes with BT), else σ = 1/T plus the reduced model's
    largest growth rate (factor e for a stable reduced model).  The H∞ norm
    is computed by the Boyd-Balakrishnan / Bruinsma-Steinbuch bisection on
    the Hamiltonian eigenvalues (:func:`hinf_norm`), whose upper end is a
    level γ at which the Hamiltonian has no imaginary eigenvalue: a certified
    upper bound (to the eigenvalue solver's backward error; eigenvalues
    within 1e-10 ‖H‖_1 of the axis count as imaginary, the safe side).
initial_state_error_bound[j] [m s^-1 s^½]
    ‖y_j - y_full,j‖_L2(0,T) of the free response from the scene's initial
    state, computed exactly from the error system's finite-horizon
    observability Gramian (Van Loan's exponential over subintervals), with a
    round-off allowance: sqrt(I (1 + 1e-8) + 1e-10 (E_full + E_red)), E the
    two models' own output energies.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import defaults
from . import modal
from .lti import LTI, output_energy

METHODS = ("auto", "bt", "galerkin", "bt_shifted")
DEFAULT_TOLERANCE = defaults.ORDER_TOLERANCE
# Output weights on the probe values of e (the velocity probes weigh 1): BT balanced mostly for the
# velocity probes (damped_forced, r = 12: velocity error 1.6e-4 at 0.1, 5.6e-4 at 1); the Galerkin
# trial space needs both halves of each standing wave (tenmode, r = 24: 4.0e-2 at 1, 5.3e-2 at 0.1).
E_WEIGHT = {"bt": 0.1, "bt_shifted": 0.1, "galerkin": 1.0}


@dataclass
class ReducedLTI:
    """A reduced linear model ẋ_r = Ar x_r + Br u, y_r = Cr x_r of an :class:`~sphrom.rom.lti.LTI`.

    Attributes
    ----------
    Ar : ndarray (r, r) [s^-1]
    Br : ndarray (r, 2)
        Column 0: the force input; column 1: the reduced initial state.
    Cr : ndarray (2P, r)
        Probe velocities, then probe values of e (rows as ``LTI.C``).
    V, W : ndarray (2N, r) or None
        Trial and test bases (x ≈ V x_r, x_r = Wᵀ x; W = V for Galerkin).
    method : str
    skew : bool
        Ar is exactly skew (d = 0, Galerkin): the energy ½|x_r|² is conserved.
    timings : dict
        Offline times [s].
    """

    Ar: np.ndarray
    Br: np.ndarray
    Cr: np.ndarray
    V: np.ndarray | None
    W: np.ndarray | None
    method: str
    skew: bool = False
    timings: dict = field(default_factory=dict)

    @property
    def order(self):
        return self.Ar.shape[0]

    @property
    def x0(self):
        """The reduced initial state, Br[:, 1] (the free response is Cr e^{Ar t} Br[:, 1])."""
        return self.Br[:, 1]

    def free_response(self, t, x0=None):
        """x_r(t) = e^{Ar t} x0 at times t, shape (M, r).

        Skew Ar: from the eigendecomposition of the Hermitian i Ar, evaluated
        at each t directly (unitary, so ½|x_r|² stays exact to round-off at
        any t); otherwise by the matrix exponential at each t.
        """
        t = np.atleast_1d(np.asarray(t, float))
        x0 = self.x0 if x0 is None else np.asarray(x0, float)
        if not self.skew:
            return np.array([sla.expm(self.Ar * ti) @ x0 for ti in t])
        lam, U = np.linalg.eigh(1j * self.Ar)          # i Ar = U diag(λ) Uᴴ, e^{Ar t} = U e^{-iλt} Uᴴ
        c = U.conj().T @ x0
        return np.real((U[None, :, :] * np.exp(-1j * np.outer(t, lam))[:, None, :]) @ c)

    def energy(self, x):
        """½|x_r|²."""
        x = np.atleast_2d(x)
        return 0.5 * np.sum(x * x, axis=-1)


@dataclass
class BalancedModel(ReducedLTI):
    """A :class:`ReducedLTI` from :func:`balanced_reduce`, with its Gramian data.

    Attributes
    ----------
    hsv : ndarray
        Hankel singular values of the weighted (and, for ``galerkin`` and
        ``bt_shifted``, shifted) system, all of them, decreasing.
    sigma : float
        Shift of the Gramians [s^-1] (0 for ``bt``).
    bt_bound : float
        2 Σ_{i>r} σ_i: for ``bt`` a bound on ‖diag(w_y) (G - G_r) diag(w_u)‖_H∞;
        for the shifted methods only an indicator.
    input_weights, output_weights : ndarray
        w_u (2,) and w_y (2P,).
    """

    hsv: np.ndarray = None
    sigma: float = 0.0
    bt_bound: float = float("nan")
    input_weights: np.ndarray = None
    output_weights: np.ndarray = None


def _factor(P):
    """A square-root factor L (L Lᵀ = P) of a symmetric positive semidefinite P (negative round-off clipped)."""
    lam, U = np.linalg.eigh(0.5 * (P + P.T))
    return U * np.sqrt(np.clip(lam, 0.0, None))


def order_from_tolerance(hsv, tolerance):
    """The smallest r with 2 Σ_{i>r} σ_i <= tolerance · 2 Σ_i σ_i (monotone in the tolerance)."""
    hsv = np.asarray(hsv, float)
    tail = np.concatenate([np.cumsum(hsv[::-1])[::-1], [0.0]])      # tail[r] = Σ_{i>=r} σ_i (0-based)
    total = tail[0]
    return int(np.argmax(tail <= tolerance * total))


def _weights(lti, method, input_weights, output_weights):
    m = lti.B.shape[1]                  # force, initial state (and the port forces of a model with ports)
    wu = np.ones(m) if input_weights is None else np.asarray(input_weights, float)
    if output_weights is None:
        p = lti.n_probes
        wy = np.concatenate([np.ones(p), np.full(p, E_WEIGHT[method])])
    else:
        wy = np.asarray(output_weights, float)
    if wy.shape[0] < lti.C.shape[0]:    # the port velocity rows after the probes' (weight 1)
        wy = np.concatenate([wy, np.ones(lti.C.shape[0] - wy.shape[0])])
    if wu.shape != (m,) or wy.shape != (lti.C.shape[0],) or np.any(wu < 0) or np.any(wy < 0):
        raise ValueError(f"input_weights: {m} numbers >= 0, output_weights: {lti.C.shape[0]} numbers >= 0")
    return wu, wy


@dataclass
class Balancing:
    """The Gramian data of :func:`balancing`: square-root factors and the SVD L_Qᵀ L_P = Z Σ Yᵀ."""

    method: str
    sigma: float
    A: np.ndarray            # the (deflated or shifted) dense A the Gramians belong to
    LP: np.ndarray
    LQ: np.ndarray
    Z: np.ndarray
    hsv: np.ndarray
    Yt: np.ndarray
    input_weights: np.ndarray
    output_weights: np.ndarray
    timings: dict
    basis: np.ndarray | None = None          # the modal path: V_m (2N, 2m), the Gramians are of ``system``
    system: LTI | None = None                # the intermediate model (:func:`sphrom.rom.modal.modal_system`)


def balancing(lti: LTI, method="auto", horizon=None, sigma=None, input_weights=None,
              output_weights=None, structure="auto") -> Balancing:
    """Gramians, their square-root factors and the Hankel singular values (the offline part of
    :func:`balanced_reduce`, reusable for several orders; arguments as there).  ``structure``
    (:func:`sphrom.rom.modal.applies`): "auto" balances a uniform scene above N = 1000 through its Fourier modes
    (reduce-then-balance, :mod:`sphrom.rom.modal`), "dense" always densely, "modal" through the modes."""
    if modal.applies(lti, structure):
        ms = modal.modal_system(lti)
        bal = balancing(ms.system, method, horizon, sigma, input_weights, output_weights, structure="dense")
        return dataclasses.replace(bal, basis=ms.basis, system=ms.system, timings=dict(bal.timings, **ms.timings))
    if method not in METHODS:
        raise ValueError(f"method: {method!r} (allowed: {', '.join(METHODS)})")
    if method == "auto":
        method = "bt" if lti.damped else "galerkin"
    if method == "bt" and not lti.damped:
        raise ValueError("method 'bt': d = 0 at some particle, so A has poles on the imaginary axis and "
                         "balanced truncation does not apply (allowed here: 'galerkin', 'bt_shifted', 'auto')")
    T = float(lti.T if horizon is None else horizon)
    if not (np.isfinite(T) and T > 0):
        raise ValueError(f"horizon: {horizon} is out of range (allowed: a number > 0)")
    wu, wy = _weights(lti, method, input_weights, output_weights)
    shift = 0.0 if method == "bt" else (1.0 / T if sigma is None else float(sigma))
    if method != "bt" and not shift > 0:
        raise ValueError(f"sigma: {sigma} is out of range (allowed: a number > 0)")
    t0 = time.perf_counter()
    if method == "bt":
        As = lti.dense(deflate=float(np.min(lti.R.diagonal()[:lti.n])))   # null modes to -min(d)
    else:
        As = lti.dense(shift=shift)
    Bw = lti.B * wu
    Cw = lti.C * wy[:, None]
    P = sla.solve_continuous_lyapunov(As, -Bw @ Bw.T)            # A P + P Aᵀ + B Bᵀ = 0
    Q = sla.solve_continuous_lyapunov(As.T, -Cw.T @ Cw)          # Aᵀ Q + Q A + Cᵀ C = 0
    t1 = time.perf_counter()
    LP, LQ = _factor(P), _factor(Q)
    Z, hsv, Yt = np.linalg.svd(LQ.T @ LP)
    t2 = time.perf_counter()
    return Balancing(method=method, sigma=shift, A=As, LP=LP, LQ=LQ, Z=Z, hsv=hsv, Yt=Yt, input_weights=wu,
                     output_weights=wy, timings={"lyapunov": t1 - t0, "svd": t2 - t1})


def truncate(lti: LTI, bal: Balancing, order) -> BalancedModel:
    """The reduced model of order r from a :class:`Balancing` (module docstring)."""
    r = int(order)
    if not (1 <= r < lti.order):
        raise ValueError(f"order: {order} is out of range (allowed: 1 to {lti.order - 1})")
    if bal.basis is not None:                                      # the modal path: truncate there, lift V, W
        from .modal import lift
        return lift(truncate(bal.system, dataclasses.replace(bal, basis=None, system=None),
                             min(r, bal.system.order - 1)), bal.basis)
    r = min(r, int(np.sum(bal.hsv > bal.hsv[0] * 1e-14)))          # never divide by a zero singular value
    t0 = time.perf_counter()
    s = np.sqrt(bal.hsv[:r])
    V = bal.LP @ bal.Yt[:r].T / s
    W = bal.LQ @ bal.Z[:, :r] / s
    skew = False
    if bal.method == "bt":
        Ar = W.T @ (bal.A @ V)
        Br, Cr = W.T @ lti.B, lti.C @ V
    elif bal.method == "bt_shifted":
        Ar = W.T @ (bal.A @ V) + bal.sigma * np.eye(r)
        Br, Cr = W.T @ lti.B, lti.C @ V
    else:
        V, _ = np.linalg.qr(V)
        W = V
        Jr = V.T @ (lti.J @ V)
        Rr = V.T @ (lti.R @ V)
        Jr = 0.5 * (Jr - Jr.T)                                     # exactly skew
        Rr = 0.5 * (Rr + Rr.T)
        skew = not np.any(Rr)
        Ar = Jr - Rr
        Br, Cr = V.T @ lti.B, lti.C @ V
    timings = dict(bal.timings, projection=time.perf_counter() - t0)
    return BalancedModel(Ar=Ar, Br=Br, Cr=Cr, V=V, W=W, method=bal.method, skew=skew, timings=timings,
                         hsv=bal.hsv, sigma=bal.sigma, bt_bound=float(2.0 * np.sum(bal.hsv[r:])),
                         input_weights=bal.input_weights, output_weights=bal.output_weights)


def balanced_reduce(lti: LTI, order=None, tolerance=None, method="auto", horizon=None, sigma=None,
                    input_weights=None, output_weights=None) -> BalancedModel:
    """Reduce the full linear SPH by balancing (module docstring).

    Parameters
    ----------
    lti : LTI
        From :func:`sphrom.rom.lti.full_linear_system`.
    order : int, optional
        r, the dimension of the reduced state (1 <= r < 2N).
    tolerance : float, optional
        Relative: the smallest r with 2 Σ_{i>r} σ_i <= tolerance · 2 Σ_i σ_i
        (default 1e-3 when ``order`` is not given either).
    method : {"auto", "bt", "galerkin", "bt_shifted"}
        ``auto``: ``bt`` when d > 0 at every particle, else ``galerkin``.
    horizon : float, optional
        T [s] (default the scene's), for the shift σ = 1/T.
    sigma : float, optional
        Shift of the Gramians [s^-1] for ``galerkin``/``bt_shifted`` (default 1/T).
    input_weights : (2,), optional
        Weights of B's columns (force, initial state) in the Gramians (default 1, 1).
    output_weights : (2P,), optional
        Weights of C's rows (default 1 on the velocities, ``E_WEIGHT[method]`` on e).

    Returns
    -------
    BalancedModel
        Br, Cr unweighted (physical units); ``timings``: ``lyapunov``, ``svd``, ``projection`` [s].
    """
    if order is not None and not (1 <= int(order) < lti.order):
        raise ValueError(f"order: {order} is out of range (allowed: 1 to {lti.order - 1})")
    if tolerance is not None and not (np.isfinite(tolerance) and 0 < tolerance < 1):
        raise ValueError(f"tolerance: {tolerance} is out of range (allowed: 0 < tolerance < 1)")
    bal = balancing(lti, method=method, horizon=horizon, sigma=sigma, input_weights=input_weights,
                    output_weights=output_weights)
    if order is None:
        order = max(1, order_from_tolerance(bal.hsv, DEFAULT_TOLERANCE if tolerance is None else tolerance))
    return truncate(lti, bal, order)


def reduced_from_exact(lti: LTI, ops) -> ReducedLTI:
    """The exact POD model (:class:`sphrom.rom.exact_linear.LinearOperators`) as a Galerkin model of ``lti``.

    V = blockdiag(√ρ0 U_v, √c U_e) is orthonormal (the modes are ρ0- and
    c-orthonormal) and ops.A = Vᵀ A V, ops.z0 = Vᵀ x0; Br = Vᵀ B, Cr = C V.
    """
    t0 = time.perf_counter()
    V = sla.block_diag(lti.w_v[:, None] * ops.U_v, lti.w_e[:, None] * ops.U_e)
    Ar = np.asarray(ops.A, float)
    return ReducedLTI(Ar=Ar, Br=V.T @ lti.B, Cr=lti.C @ V, V=V, W=V, method="exact_pod", skew=bool(ops.skew),
                      timings={"projection": time.perf_counter() - t0, **ops.timings})


# ---------------------------------------------------------------------------
# system norms
# ---------------------------------------------------------------------------
def hinf_norm(A, b, c, margin, response=None, tol=1e-4, max_iter=60, omega_scale=None, imag_tol=1e-10):
    """Certified upper bound on the H∞ norm of the SISO system c (sI - A)^-1 b, A asymptotically stable.

    Boyd-Balakrishnan bisection in the two-step form of Bruinsma and
    Steinbuch: a level γ is above ‖G‖∞ iff the Hamiltonian
    H(γ) = [[A, b bᵀ/γ], [-cᵀ c/γ, -Aᵀ]] has no imaginary eigenvalue; each
    step evaluates |G(iω)| between the imaginary eigenvalues found at
    γ = (1 + 2 tol) γ_lb, until there are none.

    Eigenvalues with |Re λ| <= imag_tol ‖H‖_1 count as imaginary (the safe
    side: the backward error of the eigensolver is ~1e-16 ‖H‖_1, so a true
    crossing is missed only if its condition number exceeds ~1e6).  That
    threshold must stay below the decay rate of A, or A's own eigenvalues
    (which H keeps when they are uncontrollable or unobservable) would pass
    for crossings; since ‖H(γ)‖ grows like |b||c|/γ, a level is tested only
    when imag_tol ‖H(γ)‖_1 <= margin/4, which puts a floor of about
    4 imag_tol |b||c| / margin under the returned bound (a system whose
    norm is below it gets the floor: certified, not tight).

    Parameters
    ----------
    A : ndarray (n, n)
    b, c : ndarray (n,)
    margin : float
        Decay rate of A, -max Re λ(A) > 0 [s^-1] (a lower bound will do).
    response : callable, optional
        ω (array) -> G(iω) (array); default dense solves.
    tol : float
        Relative gap between the returned bounds (away from the floor).
    omega_scale : float, optional
        Largest frequency of the starting grid [rad s^-1] (default ‖A‖_1).

    Returns
    -------
    (lower, upper, omega_peak)
        lower = |G(iω_peak)| <= ‖G‖∞ < upper, upper the level at which H has
        no imaginary eigenvalue.
    """
    A = np.asarray(A, float)
    n = A.shape[0]
    if not margin > 0:
        raise ValueError("hinf_norm: margin must be > 0 (A asymptotically stable)")
    nb, nc = np.linalg.norm(b), np.linalg.norm(c)
    if nb == 0 or nc == 0:
        return 0.0, 0.0, 0.0
    s = np.sqrt(nc / nb)                                 # balance |b| = |c|: G unchanged
    b, c = b * s, c / s
    if response is None:
        def response(w):
            w = np.atleast_1d(w)
            return np.array([c @ np.linalg.solve(1j * wi * np.eye(n) - A, b) for wi in w])
    wmax = float(np.max(np.sum(np.abs(A), axis=0))) if omega_scale is None else float(omega_scale)
    grid = np.concatenate([[0.0], np.geomspace(max(wmax, 1e-12) * 1e-6, max(wmax, 1e-12) * 2, 400)])
    g = np.abs(response(grid))
    k = int(np.argmax(g))
    lower, peak = float(g[k]), float(grid[k])
    bb, cc = np.outer(b, b), np.outer(c, c)
    colA = np.sum(np.abs(A), axis=0)
    level = max((1.0 + 2.0 * tol) * lower, 1e-300)
    stuck = 0
    for _ in range(max_iter):
        scale = max(float(np.max(colA + np.abs(c) * np.sum(np.abs(c)) / level)),
                    float(np.max(np.sum(np.abs(A), axis=1) + np.abs(b) * np.sum(np.abs(b)) / level)))
        thr = imag_tol * scale
        if thr > 0.25 * margin:                          # not certifiable this low: raise the level
            level *= 1.01 * thr / (0.25 * margin)
            continue
        H = np.block([[A, bb / level], [-cc / level, -A.T]])
        ev = sla.eigvals(H, overwrite_a=True, check_finite=False)
        im = np.sort(np.abs(ev[np.abs(ev.real) <= thr].imag))
        if im.size == 0:
            return lower, level, peak
        pts = np.concatenate([[0.0], im])
        mids = np.concatenate([0.5 * (pts[:-1] + pts[1:]), im])
        gm = np.abs(response(mids))
        j = int(np.argmax(gm))
        if gm[j] > lower:
            lower, peak = float(gm[j]), float(mids[j])
        # next level: above the best |G| found; when the eigenvalues flagged imaginary gave no |G| above
        # the level (a tangency at round-off level, or round-off near the floor), step the level itself
        # up, by growing factors 1 + 2 tol 4^k on the k-th such step in a row
        stuck = stuck + 1 if gm[j] <= level else 0
        level = max((1.0 + 2.0 * tol) * lower, level * (1.0 + 2.0 * tol * 4.0 ** (stuck - 1)) if stuck else 0.0)
    raise RuntimeError("hinf_norm: no certified upper bound after max_iter steps")


def _sparse_response(A_full, b_full, c_full, Ar, br, cr, shift, solves=None):
    """ω -> G_err(iω) of the error system, the full part by sparse LU (A_full sparse).

    ``solves`` (a dict, optional) keeps the state responses (sI - A)^-1 b of the full and the reduced
    model per ω: the probes share A and b (only c differs), so their bisections reuse each other's solves.
    """
    n = A_full.shape[0]
    r = Ar.shape[0]
    I = sp.identity(n, format="csc")
    Ir = np.eye(r)
    solves = {} if solves is None else solves

    def response(w):
        w = np.atleast_1d(np.asarray(w, float))
        out = np.empty(w.size, complex)
        for i, wi in enumerate(w):
            if wi not in solves:
                s = 1j * wi + shift
                lu = spla.splu((s * I - A_full).tocsc())
                solves[wi] = (lu.solve(b_full.astype(complex)), np.linalg.solve(s * Ir - Ar, br) if r else None)
            x_full, x_red = solves[wi]
            out[i] = c_full @ x_full - (cr @ x_red if r else 0.0)
        return out
    return response


def error_system(lti: LTI, reduced: ReducedLTI, shift=0.0, deflate=0.0):
    """(A_e, B_e, C_e, x_e0) of the error system y_full - y_r, with A shifted by -shift (dense)."""
    A = lti.dense(deflate=deflate, shift=shift)
    r = reduced.order
    Ae = sla.block_diag(A, reduced.Ar - shift * np.eye(r))
    Be = np.vstack([lti.B, reduced.Br])
    Ce = np.hstack([lti.C, -reduced.Cr])
    return Ae, Be, Ce, Be[:, 1].copy()


def choose_shift(lti: LTI, reduced: ReducedLTI, horizon):
    """σ of :func:`error_bounds`: 0 when the error system decays at rate >= 0.1/T, else 1/T + max(α_r, 0).

    α_r is the reduced model's spectral abscissa; the full model decays at a
    positive rate (its null modes aside, which are uncontrollable and left
    out) only when d > 0 at every particle.
    """
    alpha_r = float(np.max(np.linalg.eigvals(reduced.Ar).real)) if reduced.order else -np.inf
    if lti.damped and alpha_r <= -0.1 / horizon and full_abscissa(lti) <= -0.1 / horizon:
        return 0.0, alpha_r
    return 1.0 / horizon + max(alpha_r, 0.0), alpha_r


def full_abscissa(lti: LTI):
    """max Re λ of A with the null modes moved to -min(d) (dense eigenvalues, cached in ``lti.info``)."""
    if "abscissa" not in lti.info:
        gamma = float(np.min(lti.R.diagonal()[:lti.n]))
        lti.info["abscissa"] = float(np.max(np.linalg.eigvals(lti.dense(deflate=gamma)).real))
    return lti.info["abscissa"]


def error_bounds(lti: LTI, reduced: ReducedLTI, horizon=None, sigma=None, outputs="v", tol=1e-4,
                 progress=None, structure="auto") -> dict:
    """Certified bounds on the probe errors of ``reduced`` against the full linear SPH (module docstring).

    Parameters
    ----------
    lti : LTI
    reduced : ReducedLTI
        Any reduced model of ``lti`` (balanced, exact POD, ...).
    horizon : float, optional
        T [s] (default the scene's).
    sigma : float, optional
        Shift [s^-1] (default :func:`choose_shift`).
    outputs : {"v", "all"}
        The velocity probes, or the probe values of e as well.
    tol : float
        Relative accuracy of the H∞ bisection.
    structure : {"auto", "dense", "modal"}
        :func:`sphrom.rom.modal.applies`: "auto" bounds a uniform scene above N = 1000 through its Fourier modes
        (:func:`sphrom.rom.modal.error_bounds`: the intermediate model's bounds plus the dropped modes' tail).

    Returns
    -------
    dict
        ``force_error_bound`` (P,) [s]; ``initial_state_error_bound`` (P,)
        [m s^-1 s^½] (e rows dimensionless · s^½); ``initial_state_error``
        (the computed value before the round-off allowance); ``hinf`` (P, 2)
        the bisection's lower and upper ends; ``sigma`` [s^-1], ``factor``
        e^{σT}, ``reduced_abscissa``, ``horizon``, ``timings``.
    """
    if modal.applies(lti, structure):
        return modal.error_bounds(lti, reduced, error_bounds, horizon=horizon, sigma=sigma, outputs=outputs, tol=tol,
                                  progress=progress)
    T = float(lti.T if horizon is None else horizon)
    rows = np.arange(lti.n_probes if outputs == "v" else lti.C.shape[0])
    t0 = time.perf_counter()
    shift, alpha_r = choose_shift(lti, reduced, T) if sigma is None else (float(sigma), np.nan)
    deflate = float(np.min(lti.R.diagonal()[:lti.n])) if shift == 0.0 else 0.0
    if shift == 0.0 and not (lti.damped and alpha_r < 0):
        raise ValueError("sigma: 0 needs an asymptotically stable error system (d > 0 everywhere and a stable "
                         "reduced model)")
    Ae, Be, Ce, xe0 = error_system(lti, reduced, shift=shift, deflate=deflate)
    # decay rate of the (shifted) error system: the full part's A = J - R has Re λ <= 0 (R >= 0)
    alpha_full = full_abscissa(lti) if shift == 0.0 else 0.0
    alpha_red = alpha_r if np.isfinite(alpha_r) else float(np.max(np.linalg.eigvals(reduced.Ar).real))
    margin = shift - max(alpha_full, alpha_red)
    A_full = (lti.A - deflate * sp.csr_matrix(lti.null @ lti.null.T)).tocsr()      # unshifted: the response adds σ
    hinf = np.empty((rows.size, 2))
    t1 = time.perf_counter()
    solves = {}                                              # ω -> state responses, shared by the probes
    for i, j in enumerate(rows):
        resp = _sparse_response(A_full, lti.B[:, 0], lti.C[j], reduced.Ar, reduced.Br[:, 0], reduced.Cr[j], shift,
                                solves)
        lo, hi, _ = hinf_norm(Ae, Be[:, 0], Ce[j], margin, response=resp, tol=tol)
        hinf[i] = lo, hi
        if progress is not None:
            progress.update(1)
    t2 = time.perf_counter()
    factor = float(np.exp(shift * T))
    # free response: exact output energies of [x0; 0], [0; x_r0], [x0; x_r0] over [0, T] (unshifted system)
    Ae0, _, _, _ = error_system(lti, reduced)
    mu = max(float(np.max(np.linalg.eigvalsh(-0.5 * (Ae0 + Ae0.T)))), 1e-300)
    steps = max(1, int(np.ceil(T * mu)))                     # keep e^{μ τ} <= e on each subinterval
    n = lti.order
    X = np.zeros((Ae0.shape[0], 3))
    X[:n, 0] = lti.x0
    X[n:, 1] = reduced.x0
    X[:, 2] = xe0
    E = output_energy(Ae0, None, Ce[rows], X, T / steps, np.zeros((steps + 1, 3)))
    # energies are >= 0; a probe the motion does not reach (a node: multimode's x/L = 0.5) computes ~-1e-20.
    # The round-off allowance is relative to the probe's energies, with a floor relative to the largest
    # probe's (the round-off of the sums scales with the state, not with one probe's output).
    E_full, E_red, I = (np.maximum(E[:, i], 0.0) for i in range(3))
    floor = 1e-14 * float(np.max(E_full + E_red))
    init_bound = np.sqrt(I * (1.0 + 1e-8) + 1e-10 * (E_full + E_red) + floor)
    t3 = time.perf_counter()
    return {"force_error_bound": factor * hinf[:, 1], "hinf": hinf, "initial_state_error_bound": init_bound,
            "initial_state_error": np.sqrt(I), "full_output_norm": np.sqrt(E_full), "sigma": shift,
            "factor": factor, "reduced_abscissa": alpha_red, "margin": margin, "horizon": T, "rows": rows,
            "timings": {"setup": t1 - t0, "hinf": t2 - t1, "initial_state": t3 - t2}}

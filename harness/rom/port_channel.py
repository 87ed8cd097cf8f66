"""The port channel: the full linear SPH's response to the port forces, exact in time, in the singular planes of K.

The full SPH is exactly linear in the specific volume J (eq. A.9; :mod:`.lti`), so its response to the port forces
superposes on whatever a reduced model does with the initial state and the force f: an FMU with ports is its
portless model (the paper's k POD modes for f, no port directions in its basis) plus this channel, which carries
every port force alone.  In energy coordinates x = [√ρ0 v; √c e] the full system is ẋ = A x + Σ_j b_j u_j,
u_j = F_j / area [N m^-2], b_j = [W(x - x_j, h)/√ρ0; 0] (:mod:`sphrom.sph.ports`).  With a uniform damping d each
singular triplet (σ_i, u_i, w_i) of K = ρ0^-½ G c^½ spans an invariant plane (docs/science/error-bounds.md):

    d/dt [p_i; q_i] = Λ_i [p_i; q_i] + [β_i · u; 0],   Λ_i = [[-d, σ_i], [-σ_i, 0]],   β_ij = u_iᵀ b_j,

x = Σ_i p_i [u_i; 0] + q_i [0; w_i].  From rest only the planes the ports excite ever move: within a cluster of
equal σ (a cos and a sin of one wavenumber on a uniform bar) the planes are rotated so that the port inputs fill
the first ones, and the others, which no port force reaches, are left out exactly (a port on tenmode excites one
plane of each pair: 201 of 400).  The outputs are rows over the planes in the order of the error bounds' shadow
(:func:`sphrom.rom.bounds.output_rows`): v at each probe and each port over p, e = J - 1 at the two particles of
each probe over q.

Every plane the ports excite is kept up to :data:`MAX_PLANES` (all of them on every built-in scene): the channel
is then the full linear SPH's port response, exact in time over any step with inputs held or linear.  Planes
beyond that are truncated with a static correction, the steady response they would have to the input now:
-Λ_i⁻¹ [β_i u; 0] = [0; -β_i u / σ_i] (a feedthrough into the e rows only; their velocity is zero to this order),
and a certified remainder: integrating by parts, the truncated planes' response minus their static correction is
cᵀ Λ⁻¹ (e^{Λt} b u(0) + ∫ e^{Λ(t-τ)} b du(τ)), at most Σ_{i truncated} |c_i| ‖Λ_i⁻¹‖ |β_ij| V(u_j) per port,
V(u) = |u(0)| + the total variation of u (:attr:`PortChannel.gain`).

Each plane is advanced over a step h by the exponential of its augmented matrix (:func:`step_maps`): the state,
the input's value and its change over the step, and the mean of p over the step (the wave form of the ports,
:func:`wave_forces`).  O(planes x ports) per step; fmu_src/rom_port.c repeats it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from .lti import growth_factor

MAX_PLANES = 1024           # ROM_MAX_MODES: the most planes a channel keeps (the rest: static correction and bound)
EXCITED = 1e-13             # a rotated plane whose port inputs are below this x the largest: no port reaches it
RIGID = 1e-12               # σ below this x the largest: a rigid plane (kept whatever its input: Λ is singular)
ROUNDOFF = 1e-9             # the round-off allowance of the channel's rows, relative (as the shadow's)
ROUNDOFF_STEP = 1e-15       # ... plus this per step
N_MAPS = 12                 # numbers of one plane's step maps (:func:`step_maps`)
CHUNK = 256                 # columns of the planes' residual computed at a time (:func:`plane_residual`)
DENSE_LIMIT = 4000          # N above this: no dense singular value decomposition (no channel)


@dataclass
class PortChannel:
    """The port channel of one FMU (module docstring).

    Attributes
    ----------
    ports : tuple of float
        Port positions x/L.
    n_probes : int
    lam : ndarray (n, 2, 2)
        Each kept plane's block Λ_i [s^-1], σ ascending.
    beta : ndarray (n, P)
        dp_i/dt gains β_ij per unit u_j = F_j / area [N m^-2].
    rows : ndarray (R, n)
        The outputs over the planes, R = 3 P_probes + P: v at each probe (over p), e at the two particles of each
        probe (rows P_probes + 2 j + m, over q), v at each port (over p).
    static : ndarray (R, P)
        The truncated planes' static correction per unit u (zero where every excited plane is kept).
    gain : ndarray (R, P)
        The truncated planes' remainder per unit of V(u_j): Σ |c_ri| ‖Λ_i⁻¹‖ |β_ij| (zero likewise).
    row_norm : ndarray (R,)
        ‖c_r‖ over the kept planes (the round-off allowance).
    drift : ndarray (R, 2P + 1)
        The decomposition's residual's gains (module docstring): per unit ∫|u_j| dt (the input residual), per unit
        ∫tv_j dt (the left-out planes' state through the planes' residual), per unit ∫‖w‖ dt (likewise the kept
        planes' state).
    pw, prho0 : ndarray (P_probes, 2)
        Each probe's interpolation weights and ρ0 at its two particles [kg m^-3] (the density's part).
    dx : float
        The particle spacing [m]: the energy is ½ |w|² Δx area.
    growth : float
        ω [s^-1]: the truth's e^{A t} grows by at most e^{ω t} (:func:`sphrom.rom.lti.skew_growth`: the computed
        A's round-off), which the drift carries (:meth:`ChannelState.cert`).
    info : dict
        planes of K, excited, kept, truncated, σ, timings.
    """

    ports: tuple
    n_probes: int
    lam: np.ndarray
    beta: np.ndarray
    rows: np.ndarray
    static: np.ndarray
    gain: np.ndarray
    row_norm: np.ndarray
    drift: np.ndarray
    pw: np.ndarray
    prho0: np.ndarray
    dx: float
    growth: float = 0.0
    info: dict = field(default_factory=dict)

    @property
    def planes(self):
        return int(self.lam.shape[0])

    @property
    def n_ports(self):
        return int(self.beta.shape[1])

    @property
    def n_rows(self):
        return int(self.rows.shape[0])

    @property
    def on_q(self):
        """(R,) bool: the rows over q (e at the probes' particles); the others are over p."""
        return row_on_q(self.n_probes, self.n_ports)

    @property
    def truncated(self):
        """Whether planes the ports excite were left out (the static correction and the bound's gains apply)."""
        return bool(self.info.get("truncated", 0))


def row_on_q(n_probes, n_ports):
    """(3 P_probes + P,) bool: which output rows act on q (the e rows)."""
    out = np.zeros(3 * n_probes + n_ports, bool)
    out[n_probes:3 * n_probes] = True
    return out


def applies(problem):
    """Whether the channel can be built for ``problem``: a uniform damping d (invariant planes) and N at most
    :data:`DENSE_LIMIT` (the dense singular value decomposition)."""
    d = np.asarray(problem.d, float)
    return bool(np.all(d == d[0])) and d.size <= DENSE_LIMIT


def coupling_planes(problem):
    """(K, U, σ, W): K = ρ0^-½ G c^½ (dense) and its singular triplets, σ ascending (K W = U diag σ)."""
    G = problem.neighbours.matrix().tocsr()
    w_v, w_e = np.sqrt(problem.rho0), np.sqrt(problem.c)
    K = (G.multiply(1.0 / w_v[:, None]).multiply(w_e[None, :])).toarray()
    U, sig, Wt = np.linalg.svd(K)
    order = np.argsort(sig, kind="stable")
    return K, U[:, order], sig[order], Wt.T[:, order]


def clusters(sig, tol):
    """Index arrays of the runs of equal singular values: each run's spread (largest - smallest, ascending ``sig``)
    at most ``tol`` [s^-1] (:func:`build_channel` passes the decomposition's own residual: a rotation within a run
    then leaves out couplings no larger than the round-off already there)."""
    out, start = [], 0
    for i in range(1, sig.size + 1):
        if i == sig.size or sig[i] - sig[start] > tol:
            out.append(np.arange(start, i))
            start = i
    return out


def plane_residual(lti, U, s, W, d):
    """The planes' residual [s^-1]: an upper bound of ‖A S - S Λ‖₂ over every plane of the decomposition, A the full
    linear SPH's matrix (:func:`sphrom.rom.lti.full_linear_system`, the truth's), S = [[U, 0], [0, W]] and
    Λ_i = [[-d, s_i], [-s_i, 0]]: the Frobenius norm (≥ the 2-norm) of the residual computed in extended precision
    (numpy's longdouble: every double converts to it exactly), plus the round-off of computing it there.  Each entry
    of fl(A S - S Λ) is an inner product of at most b + 2 terms (b the most nonzeros of a row of A), so it is within
    γ_{b+2} (|A| |S| + |S| |Λ|) of the exact one (the standard model of floating-point arithmetic,
    γ_m = m u / (1 - m u), u the longdouble's unit round-off: 1.1e-19 on x86-64, the double's 2.2e-16 where the two
    are one type); that matrix's Frobenius norm is computed too (the sums of squares are numpy's pairwise ones,
    within log2(terms) u relative, far below the 1e-12 the result is raised by).  A rotation within a cluster of
    unequal σ (:func:`clusters`) shows here as the off-diagonal couplings it leaves out."""
    import scipy.sparse as sp
    ld = np.longdouble
    n = U.shape[0]
    A = sp.csr_matrix(lti.A).astype(ld)
    absA = abs(A)
    eps = float(np.finfo(ld).eps)
    b = int(np.diff(A.indptr).max()) if A.nnz else 0
    gamma = (b + 2) * eps / (1 - (b + 2) * eps)
    Ad, Ac, aAd, aAc = A[:, :n], A[:, n:], absA[:, :n], absA[:, n:]
    res2 = rnd2 = 0.0
    for a in range(0, s.size, CHUNK):           # by columns: 2N x CHUNK at a time (N up to DENSE_LIMIT)
        u, w, sv = U[:, a:a + CHUNK].astype(ld), W[:, a:a + CHUNK].astype(ld), s[None, a:a + CHUNK].astype(ld)
        R_p = Ad @ u - np.vstack([-ld(d) * u, -w * sv])             # the p columns: S Λ's first column
        R_q = Ac @ w - np.vstack([u * sv, np.zeros_like(w)])        # the q columns
        au, aw, asv = np.abs(u), np.abs(w), np.abs(sv)
        G_p = aAd @ au + np.vstack([ld(abs(d)) * au, aw * asv])
        G_q = aAc @ aw + np.vstack([au * asv, np.zeros_like(aw)])
        res2 += float(np.sum(R_p * R_p) + np.sum(R_q * R_q))
        rnd2 += float(np.sum(G_p * G_p) + np.sum(G_q * G_q))
    res, rnd = np.sqrt(res2), gamma * np.sqrt(rnd2)
    return float((res + rnd) * (1 + 1e-12))


def input_residual(U, Bv):
    """Per port column ‖b_j - U Uᵀ b_j‖ (energy units per unit u_j = F_j / area) over every plane of the decomposition:
    the part of the port input the planes do not carry (U orthonormal up to round-off), computed in extended
    precision (longdouble, as :func:`plane_residual`), plus the round-off of computing it there: fl(Uᵀ b) and
    fl(U y) are inner products of N terms, within γ_N |Uᵀ| |b| and γ_N |U| |y| (y = Uᵀ b), so the computed residual
    is within γ_{N+1} (|U| (|Uᵀ| |b| + |y|) + |b|) of the exact one, whose norm is computed too (in double: its
    terms are nonnegative, so it is within γ_{N+2} of double's unit round-off relative)."""
    ld = np.longdouble
    eps = float(np.finfo(ld).eps)
    n = U.shape[0]
    Ul, Bl = U.astype(ld), Bv.astype(ld)
    y = Ul.T @ Bl
    r = Bl - Ul @ y
    aU = np.abs(U)
    G = aU @ (aU.T @ np.abs(Bv) + np.abs(y.astype(float))) + np.abs(Bv)
    gamma = (n + 1) * eps / (1 - (n + 1) * eps)
    e64 = float(np.finfo(float).eps)
    in_double = 1 + (n + 2) * e64 / (1 - (n + 2) * e64)
    return (np.linalg.norm(r.astype(float), axis=0) + gamma * np.linalg.norm(G, axis=0) * in_double) * (1 + 1e-12)


def build_channel(problem, ports, probes, *, max_planes=MAX_PLANES, truth=None):
    """The port channel of ``problem`` with ports at ``ports`` and outputs at ``probes`` (module docstring), or
    None where it does not apply (:func:`applies`: a damping that varies along the bar, or N above the limit).

    Parameters
    ----------
    problem : SPHProblem
    ports, probes : sequence of float
        Positions x/L.
    max_planes : int
        The most planes kept (the lowest σ the ports excite; the rest by their static correction).
    truth : sphrom.rom.lti.Truth, optional
        The truth's matrix and growth rate (:func:`sphrom.rom.lti.truth_matrix` of ``problem``: a packaging builds
        it once for the channel and the shadow); None: built here.
    """
    from ..sph.ports import port_kernel
    from .bounds import output_rows
    if not len(ports) or not applies(problem):
        return None
    t0 = time.perf_counter()
    n = problem.n
    K, U, sig, W = coupling_planes(problem)
    d = float(np.asarray(problem.d, float)[0])
    Bv = (port_kernel(problem, ports) / np.sqrt(problem.rho0)[None, :]).T          # (N, P) over x_v
    # a cluster is a run of singular values equal to the decomposition's own accuracy (its residual): rotating it
    # leaves out couplings no larger than that.  A relative gap (1e-9 of σ_max) took near-degenerate pairs of a
    # graded bar (σ 2.7e-7 apart on a rubber bar of c 1.4e5..2.07e6) for equal ones, and the couplings the rotation
    # dropped (1.3e-7 s^-1) drove an error of 4.6e-9 of the response past the channel's bound
    svd_residual = float(np.linalg.norm(K @ W - U * sig[None, :]))
    for idx in clusters(sig, svd_residual):  # rotate each cluster so that the inputs fill its first planes
        if idx.size > 1:
            Q, _, _ = np.linalg.svd(U[:, idx].T @ Bv)
            U[:, idx] = U[:, idx] @ Q
            W[:, idx] = W[:, idx] @ Q
    beta = U.T @ Bv                                                                # (N, P)
    s = np.einsum("ij,ij->j", U, K @ W)                                            # u_iᵀ K w_i (σ_i)
    C, _, pw, prho0 = output_rows(problem, probes, ports)
    on_q = row_on_q(len(probes), len(ports))
    c_all = np.where(on_q[:, None], C[:, n:] @ W, C[:, :n] @ U)                   # (R, N)
    size = np.linalg.norm(beta, axis=1)
    rigid = sig <= RIGID * max(float(sig[-1]), 1e-300)
    excited = (size > EXCITED * max(float(size.max()), 1e-300)) | rigid
    candidates = np.flatnonzero(excited)
    keep = np.union1d(candidates[:max(int(max_planes), int(np.count_nonzero(rigid)))], np.flatnonzero(rigid))
    rest = np.setdiff1d(np.arange(n), keep)
    lam = np.zeros((keep.size, 2, 2))
    lam[:, 0, 0] = -d
    lam[:, 0, 1] = s[keep]
    lam[:, 1, 0] = -s[keep]
    P = len(ports)
    static = np.zeros((C.shape[0], P))
    gain = np.zeros((C.shape[0], P))
    if rest.size:                   # -Λ⁻¹ [β u; 0] = [0; -β u / σ]; ‖Λ⁻¹‖₂ = 1 / the smallest singular value of Λ
        static = -np.where(on_q[:, None], (c_all[:, rest] / s[rest][None, :]) @ beta[rest], 0.0)
        lam_rest = np.zeros((rest.size, 2, 2))
        lam_rest[:, 0, 0], lam_rest[:, 0, 1], lam_rest[:, 1, 0] = -d, s[rest], -s[rest]
        inv = 1.0 / np.linalg.svd(lam_rest, compute_uv=False)[:, -1]
        gain = (np.abs(c_all[:, rest]) * inv[None, :]) @ np.abs(beta[rest]) * (1.0 + 1e-12)
    # the decomposition's error against the truth's A (module docstring, "The decomposition's residual")
    if truth is None:
        from .lti import truth_matrix
        truth = truth_matrix(problem)
    e_norm = plane_residual(truth.lti, U, s, W, d)
    b_res = input_residual(U, Bv)
    rest_w = np.zeros(P)            # ‖w_rest(t)‖ <= Σ_j rest_w_j 2 tv_j(t) (the left-out planes' state)
    if rest.size:
        rest_w = 2.0 * np.linalg.norm(inv[:, None] * np.abs(beta[rest]), axis=0) * (1.0 + 1e-12)
    row_full = np.linalg.norm(C, axis=1) * (1.0 + 1e-12)                         # ‖c_r‖ in energy coordinates
    drift = np.hstack([row_full[:, None] * b_res[None, :], row_full[:, None] * e_norm * rest_w[None, :],
                       row_full[:, None] * e_norm])
    rows = np.ascontiguousarray(c_all[:, keep])
    return PortChannel(ports=tuple(float(x) for x in ports), n_probes=len(probes), lam=lam,
                       beta=np.ascontiguousarray(beta[keep]), rows=rows, static=static, gain=gain, drift=drift,
                       row_norm=np.linalg.norm(rows, axis=1), pw=pw, prho0=prho0, dx=float(problem.neighbours.dx),
                       growth=truth.growth, info={"planes_of_K": int(n), "excited": int(np.count_nonzero(excited)), "kept": int(keep.size),
                             "truncated": int(np.count_nonzero(excited[rest])) if rest.size else 0,
                             "sigma_max": float(sig[-1]), "sigma_kept": float(s[keep].max()) if keep.size else 0.0,
                             "d": d, "residual": e_norm, "input_residual": b_res.tolist(),
                             "svd_residual": svd_residual, "timings": {"channel": time.perf_counter() - t0}})


def step_maps(lam, h):
    """(n, 12) per plane, the maps of a step of length h [s] (module docstring): Φ (4, row-major), g0 (2), g1 (2),
    ψ (2), ψ0, ψ1, so that with u(τ) = u0 + du τ / h and v = β_i · u:

        [p, q](h) = Φ [p, q](0) + g0 v(u0) + g1 v(du),   mean of p over the step = ψ · [p, q](0) + ψ0 v(u0) + ψ1 v(du).

    From the exponential of the augmented matrix over (p, q, mean p, mean q, u0, du):
    [[Λ h, 0, [h; 0], 0], [I, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]] (the mean's rows unscaled: its state is
    ∫_0^h w dτ / h)."""
    lam = np.asarray(lam, float)
    out = np.empty((lam.shape[0], N_MAPS))
    M = np.zeros((6, 6))
    M[2, 0] = M[3, 1] = 1.0
    M[4, 5] = 1.0
    M[0, 4] = h
    for i, L in enumerate(lam):
        M[:2, :2] = L * h
        E = sla.expm(M)
        out[i, 0:4] = E[:2, :2].ravel()
        out[i, 4:6] = E[:2, 4]
        out[i, 6:8] = E[:2, 5]
        out[i, 8:10] = E[2, :2]
        out[i, 10] = E[2, 4]
        out[i, 11] = E[2, 5]
    return out


class ChannelState:
    """The channel stepped as the FMU steps it (fmu_src/rom_port.c; not bit for bit: its exponentials are the C
    core's Taylor series, these scipy's).

    Parameters
    ----------
    channel : PortChannel
    """

    def __init__(self, channel: PortChannel):
        self.ch = channel
        self.w = np.zeros((channel.planes, 2))
        self.tv = np.zeros(channel.n_ports)            # |u(0)| + the total variation of each u_j so far
        self.u_int = np.zeros(channel.n_ports)         # bounds of ∫|u_j| dt, ∫tv_j dt, ∫‖w‖ dt so far (the drift)
        self.tv_int = np.zeros(channel.n_ports)
        self.w_int = 0.0
        self.u_prev = np.zeros(channel.n_ports)
        self.steps = 0
        self.elapsed = 0.0                             # [s] the steps' sum (the drift's growth, e^{ω t})
        self._maps = {}
        self.applied = np.zeros(channel.n_ports)       # the wave form: the force held over the last step [N]
        self.reflected = np.zeros(channel.n_ports)     # ... b_j = F_j - a_j [N]

    def maps(self, h):
        key = float(h)
        if key not in self._maps:
            if len(self._maps) >= 2:
                self._maps.pop(next(iter(self._maps)))
            self._maps[key] = step_maps(self.ch.lam, key)
        return self._maps[key]

    def mean_port_velocity(self, h, u, du):
        """The mean of each port's velocity over a step h [m s^-1] from the state now with inputs u (P,) at the step's
        start and du their change over it [N m^-2]."""
        m = self.maps(h)
        vu, vd = self.ch.beta @ u, self.ch.beta @ du
        mean_p = m[:, 8] * self.w[:, 0] + m[:, 9] * self.w[:, 1] + m[:, 10] * vu + m[:, 11] * vd
        return self.ch.rows[3 * self.ch.n_probes:] @ mean_p

    def step(self, h, u, du=None):
        """Advance over h [s] with the port inputs u (P,) at the step's start [N m^-2], going linearly by du over the
        step (None: held).  Returns the mean port velocities over the step (P,) [m s^-1]."""
        u = np.asarray(u, float)
        du = np.zeros_like(u) if du is None else np.asarray(du, float)
        self.tv += np.abs(u - self.u_prev) + np.abs(du)
        self.u_prev = u + du
        self._drift(h, u, du)
        mean = self.mean_port_velocity(h, u, du)
        m = self.maps(h)
        vu, vd = self.ch.beta @ u, self.ch.beta @ du
        p, q = self.w[:, 0].copy(), self.w[:, 1].copy()
        self.w[:, 0] = m[:, 0] * p + m[:, 1] * q + m[:, 4] * vu + m[:, 6] * vd
        self.w[:, 1] = m[:, 2] * p + m[:, 3] * q + m[:, 5] * vu + m[:, 7] * vd
        self.steps += 1
        self.elapsed += float(h)
        return mean

    def _drift(self, h, u, du):
        """The drift's integrals over a step h (fmu_src/rom_port.c channel_drift): u linear over the step, so |u_j| <=
        max(|u_j|, |u_j + du_j|) = m_j; each plane's e^{Λ τ} is a contraction (d >= 0), so ‖w(τ)‖ <= ‖w(0)‖ +
        τ ‖β‖_F ‖m‖; tv_j (already at the step's end) bounds tv_j(τ) over it."""
        m = np.maximum(np.abs(u), np.abs(u + du))
        self.u_int += h * m
        self.tv_int += h * self.tv
        self.w_int += h * float(np.linalg.norm(self.w)) + 0.5 * h * h * float(np.linalg.norm(self.ch.beta)) * \
            float(np.linalg.norm(m))

    def fmu_step(self, h, forces, rates=None, area=1.0, impedance=0.0, waves=None, v_own=None, wave_rates=None):
        """One doStep as fmu_src/rom_port.c takes it: the force form (``impedance`` 0) with the port forces [N] at the
        step's start and their rates [N s^-1] (None: held), or the wave form with the incident waves ``waves`` [N]
        at the step's start, their rates ``wave_rates`` [N s^-1] (None: held) and the model's own mean port
        velocity ``v_own`` over the step [m s^-1] (:func:`wave_forces`)."""
        forces = np.asarray(forces, float)
        if impedance > 0:
            a_bar = mean_waves(h, waves, wave_rates)
            F = wave_forces(self, h, a_bar, impedance, area, v_own)
            self.applied, self.reflected = F, a_bar - F
            return self.step(h, F / area)
        du = None if rates is None else np.asarray(rates, float) * h / area
        return self.step(h, forces / area, du)

    def inputs_now(self, forces, area=1.0, impedance=0.0):
        """The port inputs now [N m^-2] (the static correction's): the forces ``forces`` [N] over the area, or in
        the wave form the force held over the last step."""
        return (self.applied if impedance > 0 else np.asarray(forces, float)) / area

    def rows(self, u_now):
        """The channel's part of every output row (R,) with the port inputs now ``u_now`` (P,) [N m^-2] (the
        static correction's)."""
        comp = np.where(self.ch.on_q[:, None], self.w[:, 1][None, :], self.w[:, 0][None, :])
        return np.sum(self.ch.rows * comp, axis=1) + self.ch.static @ np.asarray(u_now, float)

    def cert(self):
        """The certified bound of each row's channel part against the full linear SPH's port response (R,): the
        truncated planes' gains times V(u), the decomposition's drift (its residuals' gains times the integrals,
        which n additions of positive terms leave within (1 + ε)^n <= 1 + ROUNDOFF_STEP n of their exact sums; the
        Duhamel integrals' ‖e^{A (t - τ)}‖ <= e^{ω t}, :attr:`PortChannel.growth`), and the round-off allowance."""
        P = self.ch.n_ports
        D = self.ch.drift
        growth = growth_factor(self.ch.growth, self.elapsed)
        drift = (D[:, :P] @ self.u_int + D[:, P:2 * P] @ self.tv_int + D[:, 2 * P] * self.w_int) * \
            (1.0 + ROUNDOFF_STEP * self.steps) * growth
        allow = (ROUNDOFF + ROUNDOFF_STEP * self.steps) * self.ch.row_norm * float(np.linalg.norm(self.w))
        return self.ch.gain @ self.tv + drift + allow

    def energy(self, area=1.0):
        """The channel's energy ½ |w|² Δx area [J]: the full linear SPH's energy of the port response (every plane it
        excites kept)."""
        return 0.5 * float(np.sum(self.w * self.w)) * self.ch.dx * float(area)


def probe_outputs(channel, values):
    """(v at the probes (..., P), e at their two particles (..., P, 2), v at the ports (..., P_ports)) of row values
    (..., R) in the channel's order."""
    values = np.asarray(values, float)
    P = channel.n_probes
    return values[..., :P], values[..., P:3 * P].reshape(values.shape[:-1] + (P, 2)), values[..., 3 * P:]


def density_shift(channel, e):
    """The channel's part of the probe densities [kg m^-3] from its e at the probes' two particles (..., P, 2): the
    linear SPH's Σ_m pw_m ρ0_m (1 / (1 + e_m) - 1), added to a model's own density (the frozen kind's; the linear
    kinds add e itself to theirs)."""
    e = np.asarray(e, float)
    return np.sum(channel.pw * channel.prho0 * (1.0 / (1.0 + e) - 1.0), axis=-1)


def mean_waves(h, waves, rates=None):
    """The incident waves' means over a step h [N]: a (held, bit for bit) or, with rates ȧ [N s^-1] (input
    derivatives: a(t) = a + ȧ (t - t_k) over the step), a + ȧ h / 2, where a rate is nonzero.  The wave form holds
    the port force at the mean of 2 a(t) - Z v(t) over the step, so a linear incident wave enters exactly through
    its mean (fmu_src/rom_port.c)."""
    waves = np.asarray(waves, float)
    if rates is None:
        return waves.copy()
    rates = np.asarray(rates, float)
    return np.where(rates != 0.0, waves + 0.5 * rates * h, waves)


def wave_forces(state: ChannelState, h, waves, impedance, area, v_other=None):
    """The port forces F (P,) [N] held over a step h of the wave form (docs/fmu/coupling.md): F = 2 a - Z v̄, v̄ the
    mean port velocity over the step (the channel's, linear in F, plus ``v_other``, the model's own part), solved
    exactly: (I + Z M / area) F = 2 a - Z (v̄_free + v_other), M the channel's mean port velocity per unit u.  The
    reflected wave is b = a - F = Z v̄ - a, and the power F v̄ = (a² - b²) / Z."""
    waves = np.asarray(waves, float)
    P = waves.size
    zero = np.zeros(P)
    free = state.mean_port_velocity(h, zero, zero) + (0.0 if v_other is None else np.asarray(v_other, float))
    M = np.column_stack([state.mean_port_velocity(h, np.eye(P)[j], zero) - state.mean_port_velocity(h, zero, zero)
                         for j in range(P)])
    return np.linalg.solve(np.eye(P) + impedance * M / area, 2.0 * waves - impedance * free)


# ---------------------------------------------------------------------------------------------------------------
# resources/model.bin (sections PC*, fmu_src/rom_port.c) and the FMU's packaging
# ---------------------------------------------------------------------------------------------------------------

def sections(channel: PortChannel):
    """{tag: 2-D float64 array} of the channel for resources/model.bin (harness/fmu/layout.py SECTIONS PC*):

    PCSCAL (1, 6)      planes, ports, rows, truncated (0 or 1), dx [m], the drift's growth rate ω [s^-1]
    PCLAM (planes, 4)  each plane's block Λ_i row-major [s^-1]
    PCB (planes, P)    β_ij [per N m^-2]
    PCC (R, planes)    the output rows (probe v over p, e at the probes' particles over q, port v over p)
    PCD (R, 4P + 1)    the static correction per unit u, then the truncated planes' gains, then the drift's gains
                       (:attr:`PortChannel.drift`)
    PCPROBE (P_probes, 4)  each probe's weights and ρ0 at its two particles
    """
    scal = dict(planes=channel.planes, ports=channel.n_ports, rows=channel.n_rows,
                truncated=1.0 if channel.truncated else 0.0, dx=channel.dx, growth=channel.growth)
    scal = [scal[name] for name in PCSCAL_COLUMNS]
    return {"PCSCAL": np.array([scal], float), "PCLAM": channel.lam.reshape(-1, 4).copy(),
            "PCB": np.ascontiguousarray(channel.beta, float), "PCC": np.ascontiguousarray(channel.rows, float),
            "PCD": np.hstack([channel.static, channel.gain, channel.drift]),
            "PCPROBE": np.hstack([channel.pw, channel.prho0])}


PCSCAL_COLUMNS = ("planes", "ports", "rows", "truncated", "dx", "growth")   # section PCSCAL's columns (= fmu.layout's)


def _pcscal(name):
    return PCSCAL_COLUMNS.index(name)


def from_sections(found, ports=None):
    """The :class:`PortChannel` of a model.bin's sections ``found`` (tag -> array), None without them."""
    scal = found.get("PCSCAL")
    if scal is None:
        return None
    P = int(scal[0, _pcscal("ports")])
    n_probes = found["PCPROBE"].shape[0]
    D = np.asarray(found["PCD"], float)
    positions = tuple(float(x) for x in found["PORTX"][0]) if "PORTX" in found else tuple(range(P))
    return PortChannel(ports=positions if ports is None else tuple(ports), n_probes=n_probes,
                       lam=np.asarray(found["PCLAM"], float).reshape(-1, 2, 2), beta=np.asarray(found["PCB"], float),
                       rows=np.asarray(found["PCC"], float), static=D[:, :P], gain=D[:, P:2 * P], drift=D[:, 2 * P:],
                       row_norm=np.linalg.norm(found["PCC"], axis=1), pw=found["PCPROBE"][:, :2],
                       prho0=found["PCPROBE"][:, 2:], dx=float(scal[0, _pcscal("dx")]),
                       growth=float(scal[0, _pcscal("growth")]),
                       info={"truncated": int(scal[0, _pcscal("truncated")])})


def attach(ops, problem, ports, probes, channel=None, truth=None):
    """``ops`` (a model built without ports) with the port channel of ``ports``: its ``channel``, ``ports`` and the
    port velocity rows of its own coordinates ``Cp`` (its part of v_port: the response to f and the initial state,
    which no port force moves), and no port input rows (``Bp`` None: the channel takes every port force).  The
    operators of an FMU with ports (:mod:`sphrom.fmu.kinds`).  ``truth``: the packaging's truth's matrix for
    :func:`build_channel` (:func:`sphrom.rom.lti.truth_matrix`; None: built there)."""
    import dataclasses
    channel = channel or build_channel(problem, ports, probes, truth=truth)
    Cp = np.ascontiguousarray(ops.port_velocity_rows(problem, ports))
    return dataclasses.replace(ops, ports=tuple(float(x) for x in ports), Bp=None, Cp=Cp, channel=channel)


def model_ports(problem, ports, build_options=None):
    """(the ports a model's own build takes, its build options without ``port_channel``, whether the channel takes
    the ports): with ports where the channel :func:`applies` (and the build option ``port_channel`` is not False,
    the ports in the basis as before: benchmarks) the model is built without ports and the channel is
    :func:`attach`\\ ed to it."""
    options = dict(build_options or {})
    wanted = bool(options.pop("port_channel", True))
    channel = bool(len(ports)) and wanted and applies(problem)
    return (() if channel or not len(ports) else tuple(ports)), options, channel


def scene_applies(scene):
    """Whether an FMU of ``scene`` with ports gets the port channel (:func:`applies` of its problem)."""
    from ..sph.solver import build_problem
    return applies(build_problem(scene))


def run_channel(channel, t, port_forces, *, area=1.0, hold="held"):
    """The channel's rows (len(t), R) at the communication points ``t`` (t[0] = 0, a uniform step) under the port
    forces ``port_forces(t) -> (len(t), P)`` [N], held over each step or linear between its ends (``hold``): the
    port part of a model's outputs (:func:`probe_outputs`), as the FMU steps it."""
    t = np.asarray(t, float)
    F = np.asarray(port_forces(t), float).reshape(t.size, channel.n_ports)
    state = ChannelState(channel)
    out = [state.rows(np.zeros(channel.n_ports))]
    for n in range(t.size - 1):
        h = t[n + 1] - t[n]
        rates = None if hold == "held" else (F[n + 1] - F[n]) / h
        state.fmu_step(h, F[n], rates, area)
        out.append(state.rows((F[n] if hold == "held" else F[n + 1]) / area))
    return np.array(out)

"""Certified a posteriori error bounds of every reduced model's outputs: the modal shadow and its decaying complement.

The truth is the full SPH of eqs. 2.10-2.11, exactly linear in the specific volume (:mod:`.lti`): in energy
coordinates x = [√ρ0 v; √c e] it is ẋ = A x + B u, with the input u the FMU received (the force f and each port
force F_j / area, held or linear over each communication step) from x(0) = s x0 (s = initial_state_scale),
integrated exactly in time.  Every output is a row over x: the probe velocity (v_probe_j), e at the two particles
around each probe (the density), the port velocity (v_port_j).

The planes (:mod:`.planes`).  A is block diagonal in invariant planes: the singular triplets of K for a uniform d
(orthonormal), the eigenvectors of A for a damping that varies (with their conditioning).  In each plane i the
state z_i = W_iᵀ x obeys z_i' = Λ_i z_i + b̂_i u, and an output is y_r = Σ_i ĉ_riᵀ z_i (ĉ_ri = V_iᵀ c_r).

The shadow keeps a set of planes s (the lowest, or those an input reaches, :func:`choose_planes`): w' = Λ_s w + b̂_s u, w(0) = s W_sᵀ x0, stepped exactly (each plane by the
exponential of its augmented matrix), O(k_s) per step, no N.  What it leaves out, the complement, is written
with one integration by parts per plane (u(τ) = 0 before the start, dμ its jumps and slopes):

    z_i(t) = e^{Λ_i t} s η_i  -  Λ_i^-1 b̂_i u(t⁻)  +  Λ_i^-1 ∫_[0,t] e^{Λ_i (t-τ)} b̂_i dμ(τ),

so that the complement's part of row r is s g_r(t) + D_r u(t⁻) + R_r(t):

- D_r = Σ_{i∉s} ĉ_riᵀ (-Λ_i^-1) b̂_i, the complement's quasi-static response, exact: it is added to the shadow's
  row (zero on a velocity row of a uniform d: a slow force strains, it does not move);
- R_r, the complement's transient, bounded per mode in normal form (‖N^-1 e^{N τ}‖ = e^{-α τ} / |λ|,
  :func:`sphrom.rom.planes.plane_modes`) by Σ_g Σ_j H_rjg V_jg(t), V_jg = ∫ e^{-α_g (t-τ)} |dμ_j(τ)| the j-th
  input's variation weighted by the decay of group g (modes of equal decay rate share it: every underdamped plane
  of a uniform d decays at d/2): under a persistent input it saturates at a level set by the input's size and
  rate, not its history;
- g_r(t) = Σ_{i∉s} ĉ_riᵀ e^{Λ_i t} η_i, the complement's free response from the initial state: a fixed function
  of time, tabulated as a certified envelope (the largest |g_r| over each interval of a table up to TABLE_SPAN x
  the scene's T, from its exact values on a fine grid plus the modes' variation between them), and beyond the
  table the modes' decaying Hölder sum Σ_g G_rg e^{-α_g (t - t_tab)}.

The round-off of the planes (E = A V_s - V_s Λ_s) adds ‖c_r‖ ‖E‖ ∫‖w‖, and an allowance (1e-9 + 1e-15 n) ‖c_r‖
(‖w‖ + |s| ‖x0‖) covers the floating-point arithmetic of the shadow and of an exact-in-time reference.  The density
ρ = Σ_m pw_m ρ0_m / (1 + e_m) at a probe follows from the bounds β_m of e at its two particles: |ρ_model -
ρ_true| <= |ρ_model - ρ_s| + Σ_m pw_m ρ0_m β_m / ((1 + e_s,m)(1 + e_s,m - β_m)), infinite when 1 + e_s,m - β_m
<= 0.

Any N: above :data:`sphrom.rom.planes.DENSE_LIMIT` particles only the lowest planes are computed (a sparse
eigensolver, K is banded) and the planes never computed (σ >= σ_cut) are bounded through norms, never formed:
Σ |γ'||β'| / |λ| <= κ(σ_cut) ‖c_tail‖ ‖b_tail‖ / σ_cut and likewise for the free response and the quasi-static
part, ‖c_tail‖ = ‖c - V Vᵀ c‖ over the computed planes.  Their free response from x0, input-independent, is
computed instead where that is affordable (:func:`tail_table`: the full sparse system propagated from x0_tail, or
at larger N a Chebyshev expansion in K Kᵀ and Kᵀ K, into the free response's table with a certified error).

Parametric models (uniform c and d, :mod:`.parametric`): the planes are affine in (c, d) about c_ref; the complement
planes are stored and the C core (and :meth:`Shadow.at`) computes D, the gains and the decaying Hölder sums of the
initial state at the model's (c, d) once, when c and d are fixed (no table).

The shadow's size is chosen per input channel (:func:`choose_planes`): the force profile and each port with a
reference step and an in-band sine over REFERENCE_SPAN x T, and the initial state; the fewest planes (a prefix of the
planes' clusters, lowest first or by their complement terms, whichever is smaller, less the clusters no allowance
needs; with the free response's table of TABLE_NODES nodes that keeps the fewest) whose certified complement stays
within each channel's allowance: :data:`SHADOW_TARGET` of its response, or, where larger and known,
:data:`MODEL_FRACTION` x the model's own error on that reference input (``model_runs``, :func:`model_errors`: the FMU's
core runs the model at packaging), at most :data:`MAX_PLANES`.  Port forces as inputs of the shadow (no port channel
exact on its own) with N <= :data:`PORT_ALL_PLANES`: every plane, since a port's force and velocity are spread and
read by the kernel over a few particles and reach every plane alike (the complement is then empty and the port bounds
|model - truth| up to round-off, at O(N) per step).  Likewise every plane where even :data:`MAX_PLANES` leave a
complement above :data:`ALL_PLANES_ABOVE` of a channel's response and above its allowance, and every plane is
computed (N <= :data:`ALL_PLANES`).  docs/science/error-bounds.md has the derivation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.fft as sf
import scipy.linalg as sla

from ..sph.ports import port_kernel, port_velocity_rows
from .lti import growth_factor, probe_matrix, truth_matrix
from .planes import EIGEN_LIMIT, Modes, coupling, eigen_planes, gap_cuts, plane_modes, singular_planes

SHADOW_TARGET = 1e-6        # the complement's certified part / the channel's response, per reference input
MAX_PLANES = 96             # the largest shadow (planes; k_s = 2 x this)
PORT_ALL_PLANES = 500       # port forces as the shadow's inputs and N <= this: every plane (build_shadow)
ALL_PLANES = 2500           # N <= this (the C core's shadow planes at most: MAX_SHADOW_PLANES of fmu/layout.py) and the
ALL_PLANES_ABOVE = 1e-2     # largest cut's criterion above this: every plane (build_shadow; a complement this large a
                            # part of a response makes bounds useless)
SPARSE_PLANES = 96          # planes computed above DENSE_LIMIT particles (the shadow's and a buffer of exact ones)
INITIAL_BUDGET = 3.2e6      # ... more, up to this / N (at most MAX_COMPUTED), where the initial state's tail needs
MAX_COMPUTED = 400          # them (build_shadow; Lanczos costs ~N k²: BENCHMARKS.md, "at large N")
ROUNDOFF = 1e-11            # relative round-off allowance
ROUNDOFF_STEP = 1e-15       # ... plus this per step
SUM_ROUNDOFF = 1e-12        # the complement's sums: times (1 + this)
DECAY_FLOOR = 2.0 ** -500   # the tails' decays after the table and the variations, once positive: at least this
DECAY_FLOOR_X = 347.0       # ... e^{-x} <= DECAY_FLOOR for x >= this (> 500 ln 2)
SIZE_FLOOR = 2.0 ** -400    # the complement's positive gains and tails: at least this (so that no product the FMU
                            # forms per step is subnormal: rom_bound.c BOUND_DECAY_FLOOR; raising an upper bound)
TABLE_SPAN = 20.0           # the initial state's free response table covers this x the scene's T (at most)
MAX_NODES = 4096            # its nodes at most (at first: choose_planes tries the caps of TABLE_NODES)
TABLE_NODES = (4096, 8192, 16384, 32768)   # ... the caps tried: the one that keeps the fewest planes, then the fewest
                            # nodes that still meet the allowances with them
TABLE_VALUES = 2 ** 18      # ... within this many nodes x rows (the table's values and slopes: 8 MB x this / 2^18 / 2)
NODE_RESOLUTION = 0.1       # its spacing h: |μ| h <= this for every mode that matters (within MAX_NODES)
FINE_RESOLUTION = 0.01      # ... or this, in a table of more than MAX_NODES nodes ((0.01)^4 / 384 = 2.6e-11)
INTERPOLATED = 3.7          # a mode with |μ| h above this counts by its size, not interpolated ((3.7)^4/384 = 0.49)
PLATEAU = 2.0               # no cut meets the target: the smallest within this factor of the largest cut's value
MODEL_FRACTION = 0.5        # a channel's complement may reach this x the model's own error on it (choose_planes)
FREE_TARGET = 1e-7          # the initial state's channel's target (with a table; choose_planes), error known or not
REFERENCE_STEPS = 2000      # the reference runs' held steps over T (reference_responses, the model's runs)
FREE_SAMPLES = 4000         # the initial state's free response: intervals over TABLE_SPAN x T (choose_planes)
N_BLOCKS = 256              # its error bounds: one per block of intervals
MAX_GROUPS = 4              # decay-rate groups of the complement's transient
REFERENCE_SPAN = 20.0       # the reference sine's run: this x T (its weighted variation)
FLOOR = 1e-6                # a channel's response below this x its row class's largest is not judged (round-off)
PIECES = ("const", "c", "d")   # A(c, d) = A_const + c A_c + d A_d
TOLERANCE_FRACTION = 0.05   # error_tolerance's default: this x the training run's largest |v_probe| [m s^-1]
FMU_MAX_PARTICLES = 200000  # above this N the FMU carries no shadow
N_SCALARS = 14              # columns of section SHSCAL
TAIL_RESOLUTION = 0.5       # the uncomputed planes' free response computed: table spacing h ‖A‖ <= this
TAIL_DECAY = 1e-4           # ... over the span in which their bound decays by this (e^{-α t}); beyond, their norms
MAX_TAIL_NODES = 131072     # ... only where that takes at most this many nodes
TAIL_WORK = 2e8             # ... by the full state's propagation where N x nodes is at most this (TAYLOR_TERMS
TAYLOR_TERMS = 10           # products with A per node: e^{A h} x by its Taylor series to this power)
CHEBYSHEV_WORK = 4e9        # ... else by a Chebyshev expansion where N x its degree is at most this
CONT_ROUNDOFF = 1e-13       # the modes continued past the table: their amplitudes' relative error (the nodes')
CONT_ANCHOR = 256           # ... the steps the FMU carries their exponentials over (e^{μ h} per step) between exact anchors
TAIL_SHARE = 0.1            # ... as long as that one's certified error is below this share of the norm bound
CONT_SHARE = 0.1            # past the table the modes left out may reach this share of the bound's round-off allowance
                            # ROUNDOFF ‖c_r‖ |s| ‖x0‖ (continued_modes: it is there at every time)


# ---------------------------------------------------------------------------------------------------------------
# the shadow
# ---------------------------------------------------------------------------------------------------------------

@dataclass
class Complement:
    """The complement's terms at fixed parameters (module docstring).  Rows r, inputs j, groups g.

    Attributes
    ----------
    D : ndarray (rows, m)
        Quasi-static feedthrough, added to the shadow's rows [row units per input unit].
    static : ndarray (rows, m)
        Bound of the uncomputed planes' quasi-static part, times |u_j(t⁻)|.
    rates : ndarray (G,)
        Decay rate of each group [s^-1] (>= 0).
    gain : ndarray (rows, m, G)
        H_rjg: the transient's gain per unit weighted variation.
    h : float
        The free response table's node spacing [s] (0: no table, the tail from t = 0).
    values, slopes : ndarray (rows, n) or None
        g_r and g_r' at the nodes t_k = k h (per unit initial_state_scale; slopes per s), added to the shadow's
        rows by cubic Hermite interpolation (:func:`free_table`).
    errors : ndarray (rows, n_blocks) or None
        The interpolation's certified error over the intervals k of block k // q.
    q : int
    t_end : float
        The table's end [s] ((n - 1) h).
    tail : ndarray (rows, G)
        |g_r(t) - Re Σ_M cont_Q_rM e^{cont_mu_M (t - t_end)}| <= Σ_g tail_rg e^{-α_g (t - t_end)} for t >= t_end:
        the size of the modes not continued (and of the planes never computed).
    cont_mu : ndarray (M_c,) of complex or None
        The continued modes' exponents μ_M [s^-1] (:func:`continuation`): past the table their free response is
        added exactly, Re Σ_M cont_Q_rM e^{μ_M (t - t_end)}, with the round-off allowance :func:`cont_roundoff`.
    cont_Q : ndarray (rows, M_c) of complex or None
        Their amplitudes at the table's end, P_rM e^{μ_M t_end} (per unit initial_state_scale).
    """

    D: np.ndarray
    static: np.ndarray
    rates: np.ndarray
    gain: np.ndarray
    h: float
    values: np.ndarray | None
    slopes: np.ndarray | None
    errors: np.ndarray | None
    q: int
    t_end: float
    tail: np.ndarray
    cont_mu: np.ndarray | None = None
    cont_Q: np.ndarray | None = None


@dataclass
class Shadow:
    """The certified shadow of one FMU (module docstring).  Rows: P v probes, then e at the particles of probe j
    (rows P + 2 j, P + 2 j + 1), then the ports.  Inputs: column 0 the force f [m s^-2], column 1 + j the port
    force F_j / area [N m^-2] (without ``port_inputs``: f only).

    Attributes
    ----------
    A : ndarray (3, planes, 2, 2)
        Each plane's block in pieces: Λ(c, d) = A[0] + c A[1] + d A[2] (A[1], A[2] zero unless parametric) [s^-1].
    B : ndarray (k_s, m), C : ndarray (rows, k_s), w0 : ndarray (k_s,)
        The shadow's inputs, rows and initial state (initial_state_scale 1).
    comp : Complement or None
        The complement's terms at fixed parameters (None: parametric, see ``cplanes``).
    row_norm : ndarray (rows,)
        ‖c_r‖ in the energy coordinates (at c_ref).
    row_e : ndarray (rows,) of bool
        e rows (their dual norm scales with sqrt(c_ref / c) in a parametric model).
    x0_norm, e_norm, b_norm : float
        ‖x0‖, the planes' residual norm ‖A V_s - V_s Λ_s‖ [s^-1], ‖B_s‖.
    pw, prho0 : ndarray (P, 2)
        Each probe's interpolation weights and ρ0 at its two particles.
    n_ports : int
    parametric : bool
    c_ref : float
    E : ndarray (3, 2)
        A parametric shadow's residual pieces' norms (v rows, e rows).
    cplanes : dict or None
        A parametric shadow's complement planes: sigma (n,), chat (rows, n, 2), bv (n, m), eta (n,).
    growth : float
        ω [s^-1]: the truth's e^{A t} grows by at most e^{ω t} (:func:`sphrom.rom.lti.skew_growth`, round-off of
        the computed A), which the residual's drift carries (:func:`run_shadow`); 0 for a parametric shadow (its
        residual pieces take the truth's M as -Kᵀ: a contraction).
    info : dict
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    w0: np.ndarray
    comp: Complement | None
    row_norm: np.ndarray
    row_e: np.ndarray
    x0_norm: float
    e_norm: float
    b_norm: float
    pw: np.ndarray
    prho0: np.ndarray
    n_ports: int
    parametric: bool = False
    c_ref: float = float("nan")
    E: np.ndarray = field(default_factory=lambda: np.zeros((3, 2)))
    cplanes: dict | None = None
    growth: float = 0.0
    info: dict = field(default_factory=dict)

    @property
    def order(self):
        return int(self.w0.size)

    @property
    def planes(self):
        return int(self.A.shape[1])

    @property
    def n_probes(self):
        return int(self.pw.shape[0])

    @property
    def n_rows(self):
        return int(self.C.shape[0])

    @property
    def n_inputs(self):
        return int(self.B.shape[1])

    def blocks(self, c=None, d=None):
        """The blocks Λ_i(c, d) (planes, 2, 2); c, d None: the non-parametric shadow's."""
        if not self.parametric:
            return self.A[0].copy()
        return self.A[0] + float(c) * self.A[1] + float(d) * self.A[2]

    def dual_norms(self, c=None):
        """‖c_r‖ in the energy norm of the model's c (e rows scale with sqrt(c_ref / c))."""
        if not self.parametric:
            return self.row_norm.copy()
        return np.where(self.row_e, self.row_norm * math.sqrt(self.c_ref / float(c)), self.row_norm)

    def residual_norm(self, c=None, d=None):
        """‖E(c, d)‖ in the energy norm at c (a bound: the pieces' norms summed)."""
        if not self.parametric:
            return float(self.e_norm)
        coef = (1.0, float(c), float(d))
        ratio = math.sqrt(float(c) / self.c_ref)
        return float(sum(coef[p] * (self.E[p, 0] + ratio * self.E[p, 1]) for p in range(3)))

    def at(self, c=None, d=None):
        """The complement's terms at (c, d) (:class:`Complement`): the stored ones, or a parametric shadow's
        computed from its complement planes (:func:`parametric_complement`, as the C core does)."""
        if not self.parametric:
            return self.comp
        return parametric_complement(self.cplanes, self.c_ref, float(c), float(d))


# ---------------------------------------------------------------------------------------------------------------
# rows, inputs, initial state
# ---------------------------------------------------------------------------------------------------------------

def output_rows(problem, probes, ports=()):
    """(rows (n_rows, 2N) over energy coordinates, row_e, pw (P, 2), prho0 (P, 2)): v at each probe, e at the two
    particles around it, each port's velocity (module docstring)."""
    probes = np.asarray(probes, float)
    n = problem.rho0.size
    w_v, w_e = np.sqrt(problem.rho0), np.sqrt(problem.c)
    L = problem.scene.L
    s = np.mod(probes * L - problem.x[0], L) / (L / n)
    i0 = np.floor(s).astype(np.int64) % n
    wt = s - np.floor(s)
    i1 = (i0 + 1) % n
    P = probes.size
    rows = [np.hstack([probe_matrix(problem.x, L, probes, w_v), np.zeros((P, n))])]
    e_rows = np.zeros((2 * P, 2 * n))
    for j in range(P):
        for m, i in enumerate((i0[j], i1[j])):
            e_rows[2 * j + m, n + i] = 1.0 / w_e[i]
    rows.append(e_rows)
    if len(ports):
        rows.append(np.hstack([port_velocity_rows(problem, ports) / w_v[None, :], np.zeros((len(ports), n))]))
    C = np.vstack(rows)
    row_e = np.zeros(C.shape[0], bool)
    row_e[P:3 * P] = True
    pw = np.stack([1.0 - wt, wt], axis=1)
    prho0 = np.stack([problem.rho0[i0], problem.rho0[i1]], axis=1)
    return C, row_e, pw, prho0


def input_columns(problem, ports=()):
    """(2N, 1 + P) input columns over energy coordinates: the force profile √ρ0 profile (per m s^-2), each port's
    W(x - x_j, h)/√ρ0 (per N m^-2, i.e. per unit F_j / area; :mod:`sphrom.sph.ports`)."""
    n = problem.rho0.size
    w_v = np.sqrt(problem.rho0)
    cols = [np.concatenate([w_v * problem.profile, np.zeros(n)])]
    if len(ports):
        for k in port_kernel(problem, ports):
            cols.append(np.concatenate([k / w_v, np.zeros(n)]))
    return np.column_stack(cols)


# ---------------------------------------------------------------------------------------------------------------
# the complement's terms
# ---------------------------------------------------------------------------------------------------------------

def feedthrough(L, chat, bhat):
    """D = Σ_i ĉ_iᵀ (-L_i^-1) b̂_i over the planes (L (n, 2, 2), chat (rows, n, 2), bhat (n, 2, m)): (rows, m);
    a singular block contributes where its input reaches only its invertible part (else inf)."""
    rows, m = chat.shape[0], bhat.shape[2]
    out = np.zeros((rows, m))
    for i in range(L.shape[0]):
        b = bhat[i]
        if not np.any(b):
            continue
        try:
            x = np.linalg.solve(L[i], -b)
        except np.linalg.LinAlgError:
            x, res, rank, _ = np.linalg.lstsq(L[i], -b, rcond=None)
            if not np.allclose(L[i] @ x, -b, rtol=1e-12, atol=1e-300):
                out[:] = np.inf
                continue
        out += chat[:, i] @ x
    return out


def group_rates(alpha, max_groups=MAX_GROUPS):
    """(rates (G,), group of each α): the distinct decay rates (to 1e-9 relative), merged down to at most
    ``max_groups`` (a group's rate is the smallest of its members: each mode decays at least that fast)."""
    alpha = np.asarray(alpha, float)
    if alpha.size == 0:
        return np.zeros(0), np.zeros(0, np.int64)
    uniq = np.sort(np.unique(alpha))
    rates = [uniq[0]]
    for a in uniq[1:]:
        if a > rates[-1] * (1 + 1e-9) + 1e-300:
            rates.append(a)
    rates = np.asarray(rates)
    while rates.size > max_groups:                       # merge the closest pair (in log) into the lower rate
        lg = np.log(np.maximum(rates, 1e-300))
        k = int(np.argmin(np.diff(lg)))
        rates = np.delete(rates, k + 1)
    group = np.searchsorted(rates, alpha * (1 + 1e-9) + 1e-300, side="right") - 1
    return rates, np.clip(group, 0, rates.size - 1)


def mode_gains(modes: Modes):
    """(rows, M, m): each mode's transient gain |γ'| |β'_j| scale / |λ| (0 where no input reaches it, inf where an
    input reaches a mode with λ = 0 or no decay bound)."""
    num = modes.gamma[:, :, None] * (modes.beta * modes.scale[:, None])[None]
    with np.errstate(divide="ignore", invalid="ignore"):
        g = num / modes.absl[None, :, None]
    return np.where(num > 0, g, 0.0)


@dataclass
class Tail:
    """The planes never computed (σ >= sigma_cut), bounded through norms (module docstring): per plane i
    ‖ĉ_i‖ ‖e^{Λ_i t}‖ ‖η_i‖ <= κ e^{-α t} ‖ĉ_i‖ ‖η_i‖, summed over the tail by Cauchy-Schwarz, either plainly
    (‖c_tail‖ ‖x0_tail‖) or with the weights ω_i² = σ_i² + s, s = σ_cut² (‖c‖_ω⁻¹ ‖x0‖_ω: Σ ‖ĉ_i‖² / ω_i² and
    Σ ω_i² ‖η_i‖² come from one sparse solve with K Kᵀ + s and a product with Kᵀ, no plane formed), whichever
    is smaller.  A point row (a probe) reaches every plane alike, a smooth initial state only the low ones: the
    weights move the sum's weight onto the slowly decaying side (‖c_tail‖ ~ 1 against ‖c‖_ω⁻¹ ~ (N σ_cut)^-½)."""

    sigma_cut: float
    kappa: float              # the normal forms' condition number at sigma_cut (an upper bound beyond)
    alpha: float              # their decay rate
    inv_norm: float           # ‖Λ^-1‖ <= this for every tail plane
    c_norm: np.ndarray        # (rows,) ‖c_tail‖
    b_norm: np.ndarray        # (m,) ‖b_tail‖
    x0_norm: float            # ‖x0_tail‖
    c_weighted: np.ndarray = None   # (rows,) ‖c_tail‖_ω⁻¹ = (Σ_tail ‖ĉ_i‖² / (σ_i² + s))^½
    x0_weighted: float = math.inf   # ‖x0_tail‖_ω = (Σ_tail (σ_i² + s) ‖η_i‖²)^½
    exact: "TailTable | None" = None  # their free response computed on the full system (:func:`tail_table`)

    def _pairs(self, other):
        """Σ_tail ‖ĉ_i‖ ‖o_i‖ / σ_i for input columns o (norms ``other``): min of the plain and weighted sums."""
        plain = np.outer(self.c_norm, other) / self.sigma_cut
        if self.c_weighted is None:
            return plain
        # Σ (‖ĉ‖/ω)(ω ‖b̂‖/σ) <= ‖c‖_ω⁻¹ ‖b_tail‖ max ω/σ, ω²/σ² = 1 + s/σ² <= 2
        return np.minimum(plain, math.sqrt(2.0) * np.outer(self.c_weighted, other))

    def gain(self):
        """(rows, m): the transient's gain of the tail per unit weighted variation (Σ κ ‖ĉ‖ ‖b̂‖ / σ)."""
        return self.kappa * self._pairs(self.b_norm)

    def static(self):
        """(rows, m): the quasi-static part's bound per unit |u| (Σ ‖ĉ‖ ‖Λ^-1‖ ‖b̂‖)."""
        return self.inv_norm * self.sigma_cut * self._pairs(self.b_norm)

    def free(self):
        """(rows,): |g_tail,r(t)| <= this x e^{-α t}, the free response from x0 (Σ κ ‖ĉ‖ ‖η‖)."""
        plain = self.c_norm * self.x0_norm
        if self.c_weighted is not None:
            plain = np.minimum(plain, self.c_weighted * self.x0_weighted)
        return self.kappa * plain


@dataclass
class TailTable:
    """The uncomputed planes' free response g_tail,r(t) = c_rᵀ e^{A t} x0_tail (x0_tail = x0 - V Vᵀ x0 over the
    computed planes), computed on the full sparse system at the nodes t_k = k h, k < nodes (:func:`tail_table`),
    with the certified error of its cubic Hermite interpolation over each interval [t_k, t_k+1] (``error``): the
    modes' fourth derivatives, Σ_tail |P| |μ|⁴ h⁴ / 384 e^{-α t_k} <= (h ‖A‖)⁴ / 384 x the tail's Hölder bound
    (:meth:`Tail.free`) e^{-α t_k}, plus the propagation's and the products' round-off."""

    h: float
    t_end: float
    values: np.ndarray        # (rows, nodes)
    slopes: np.ndarray        # (rows, nodes) [per s]
    error: np.ndarray         # (rows, nodes - 1)
    a_norm: float             # ‖A‖_2 <= this [s^-1]
    seconds: float


def tail_table(problem, C, x0, planes, tail: Tail, T, truth=None):
    """The uncomputed planes' free response computed (:class:`TailTable`), or None where the tail does not decay
    (d = 0) or the table is not affordable: more than MAX_TAIL_NODES nodes, or above both work limits below.

    The span: until the tail's norm bound has decayed by TAIL_DECAY (ln(1/TAIL_DECAY) / α, at most TABLE_SPAN x T);
    the spacing h <= TAIL_RESOLUTION / ‖A‖ (‖A‖_2 <= (‖A‖_1 ‖A‖_∞)^½, every mode |μ| <= it, so the Hermite cubic
    between nodes is within (h ‖A‖)⁴ / 384 x the norm bound e^{-α t_k}).  Two ways to the nodes:

    - N x nodes <= TAIL_WORK: the full state propagated (:func:`_taylor_nodes`), e^{A h} x by its Taylor series to
      TAYLOR_TERMS, ten products with A per node; e^{A t} is a contraction in the energy norm up to the computed A's
      round-off (‖e^{A t}‖ <= e^{ω t}, :func:`sphrom.rom.lti.skew_growth`), so its errors only add, times e^{ω t_k}.
    - else, N x the Chebyshev degree <= CHEBYSHEV_WORK and x0 unstrained (x0_tail = [x_v; 0], always so for the
      SPH's x0): the response as a function of K Kᵀ and Kᵀ K (:func:`tail_free_chebyshev`), one product with K and
      Kᵀ per half unit of t σ_max (1/20 of the Taylor propagation's) but whose round-off bound grows like Q^2.5 with
      the degree Q: the table ends where its certified error reaches TAIL_SHARE of the norm bound.

    ``truth``: the truth's matrix and growth rate (:func:`sphrom.rom.lti.truth_matrix`, built here if None)."""
    if not tail.alpha > 0:
        return None
    n = problem.rho0.size
    t0 = time.perf_counter()
    if truth is None:
        from .lti import truth_matrix
        truth = truth_matrix(problem)
    A = truth.lti.A.tocsr()
    a_norm = math.sqrt(float(abs(A).sum(axis=0).max()) * float(abs(A).sum(axis=1).max())) * (1 + 1e-12)
    span = min(TABLE_SPAN * float(T), math.log(1.0 / TAIL_DECAY) / tail.alpha)
    nodes = int(math.ceil(span * a_norm / TAIL_RESOLUTION)) + 1
    K = coupling(problem)
    mu_max = 2.0 ** math.ceil(math.log2(float(abs(K).sum(axis=0).max()) * float(abs(K).sum(axis=1).max())
                                        * (1 + 1e-12)))
    taylor = n * nodes <= TAIL_WORK
    if nodes > MAX_TAIL_NODES or not (taylor or n * chebyshev_degree(span, mu_max) <= CHEBYSHEV_WORK):
        return None
    S = planes.basis(np.arange(planes.count))
    x = np.asarray(x0, float) - S @ (S.T @ np.asarray(x0, float))
    if not taylor and np.any(x[n:]):
        return None
    h = span / (nodes - 1)
    a = h * a_norm
    C = np.asarray(C, float)
    cn = np.linalg.norm(C, axis=1)
    times = np.arange(nodes) * h
    bound = np.outer(tail.free(), np.exp(-tail.alpha * times))              # the norm bound at the nodes
    if taylor:
        values, slopes, ev, es = _taylor_nodes(A, C, x, nodes, h, a, float(tail.x0_norm))
        grow = growth_factor(truth.growth, times)[None, :]        # node k's: Σ_j e^{A (t_k - t_j)} δ_j
        ev, es = ev * grow, es * grow
    else:
        values, slopes, ev, es = tail_free_chebyshev(K, C, x[:n], times, 2.0 * tail.alpha, mu_max, tail.free(),
                                                     tail.alpha)
    ev = ev + 1e-13 * np.outer(cn, np.full(nodes, np.linalg.norm(x0)))      # x0_tail's own round-off
    # the Chebyshev table ends where no row's computed error is below TAIL_SHARE of its norm bound (its round-off
    # bound grows with t); on each interval the smaller of its error and |g| + |cubic| <= the norm bound + the cubic's
    # size (each row past its own share: no worse than the norm bound by more than its computed response)
    within = np.any((ev <= TAIL_SHARE * bound) & (h * es <= TAIL_SHARE * bound), axis=0)
    last = nodes - 1 if taylor or np.all(within) else int(np.argmin(within)) - 1
    if last < 1:
        return None
    k = last + 1
    err = bound[:, :k - 1] * (a ** 4 / 384.0) + np.maximum(ev[:, :k - 1], ev[:, 1:k]) \
        + 0.25 * h * np.maximum(es[:, :k - 1], es[:, 1:k])
    cubic = np.maximum(np.abs(values[:, :k - 1]), np.abs(values[:, 1:k])) \
        + 0.25 * h * np.maximum(np.abs(slopes[:, :k - 1]), np.abs(slopes[:, 1:k]))
    err = np.minimum(err, (bound[:, :k - 1] + cubic) * (1 + 1e-12))
    return TailTable(h=h, t_end=last * h, values=values[:, :k], slopes=slopes[:, :k], error=err, a_norm=a_norm,
                     seconds=time.perf_counter() - t0)


def _taylor_nodes(A, C, x, nodes, h, a, x_norm):
    """c_rᵀ x and c_rᵀ A x at the nodes t_k = k h from x (:func:`tail_table`), e^{A h} x = Σ_{j <= J} (A h)^j x / j!
    (J = TAYLOR_TERMS; the rest <= 2 a^{J+1} / (J+1)! ‖x‖, a = h ‖A‖), with their errors: node k's state is within
    k (rest + 1e-14) ‖x0_tail‖ of the exact one (e^{A t} a contraction in the energy norm, A + Aᵀ = -2 diag(d, 0)),
    the products c_rᵀ x add 4 N ε ‖c_r‖ ‖x0_tail‖; a slope's error (h ‖Aᵀ c_r‖ <= a ‖c_r‖) is at most the value's
    x 0.6 / h.  Returns (values, slopes, value errors, slope errors), each (rows, nodes)."""
    n = x.size // 2
    rows = C.shape[0]
    values, slopes = np.zeros((rows, nodes)), np.zeros((rows, nodes))
    for k in range(nodes):
        ax = A @ x
        values[:, k] = C @ x
        slopes[:, k] = C @ ax
        if k + 1 == nodes:
            break
        term = ax * h
        y = x + term
        for j in range(2, TAYLOR_TERMS + 1):
            term = (A @ term) * (h / j)
            y += term
        x = y
    rest = 2.0 * a ** (TAYLOR_TERMS + 1) / math.factorial(TAYLOR_TERMS + 1)
    eps = np.finfo(float).eps
    cn = np.linalg.norm(C, axis=1)
    prop = (np.arange(nodes) * (rest + 1e-14) + 4 * n * eps) * x_norm
    ev = np.outer(cn, prop)
    return values, slopes, ev, ev * (0.6 / h)


def chebyshev_degree(t, mu_max):
    """The Chebyshev degree (in K Kᵀ) that resolves the free response up to time t [s]: the expansion of
    cos(t σ) in T_2j(σ / σ_max) has its coefficients (Bessel functions J_2j(t σ_max)) negligible beyond
    2j ~ t σ_max; a margin of 8 % + 64."""
    return int(math.ceil(1.08 * t * math.sqrt(mu_max) / 2.0 + 64))


def _plane_functions(lam, t, d):
    """F_t, F_t', G_t (G_t' = F_t) at the points lam (Q,) of the spectrum of K Kᵀ and the times t (B,): a plane of
    σ² = λ started at [η; 0] has v(t) = F_t(λ) η and e(t) = -σ G_t(λ) η (e^{Λt}, Λ = [[-d, σ], [-σ, 0]]):
    F = e^{-dt/2} [cos w t - (d/2) sin(w t) / w], G = e^{-dt/2} sin(w t) / w, F' = e^{-dt/2} [-d cos w t +
    (d²/2 - λ) sin(w t) / w], w = (λ - d²/4)^½ (cosh, sinh where λ < d²/4).  Returns three (Q, B) arrays."""
    z = lam - d * d / 4.0
    t = np.asarray(t, float)
    F, Fp, G = (np.empty((lam.size, t.size)) for _ in range(3))
    e = np.exp(-0.5 * d * t)[None, :]
    osc = z > 0
    if np.any(osc):
        w = np.sqrt(z[osc])[:, None]
        arg = w * t[None, :]
        c, sn = np.cos(arg), np.sin(arg) / w
        F[osc] = e * (c - 0.5 * d * sn)
        G[osc] = e * sn
        Fp[osc] = e * (-d * c + (0.5 * d * d - lam[osc, None]) * sn)
    if not np.all(osc):                       # w = iκ, κ <= d/2: e^{-dt/2} cosh κt, e^{-dt/2} sinh(κt)/κ, no overflow
        k = np.sqrt(-z[~osc])[:, None]
        tt = t[None, :]
        up, down = np.exp((k - 0.5 * d) * tt), np.exp(-(k + 0.5 * d) * tt)
        c = 0.5 * (up + down)
        small = k * tt < 1e-3
        with np.errstate(invalid="ignore", divide="ignore"):
            sn = np.where(small, tt * e * (1.0 + (k * tt) ** 2 / 6.0), 0.5 * (up - down) / np.where(small, 1.0, k))
        F[~osc] = c - 0.5 * d * sn
        G[~osc] = sn
        Fp[~osc] = -d * c + (0.5 * d * d - lam[~osc, None]) * sn
    return F, Fp, G


def _truncation(t, Q, mu_max, d):
    """(3, B) bounds of max over [0, mu_max] of |f - p| for f = F_t, F_t', G_t and p its Chebyshev interpolant of
    degree Q - 1 in λ (Q points): in σ = λ^½ the λ-coefficients are the even σ-coefficients (T_j(2σ²/σ_m² - 1) =
    T_2j(σ / σ_m)), on the Bernstein ellipse E_r of [-σ_m, σ_m] |Im σ| <= σ_m sinh u (r = e^u) and
    |Im (σ² - d²/4)^½| <= |Im σ| + d/2, |λ| <= σ_m² cosh² u, so |F| <= (1 + dt/2) e^{t σ_m sinh u},
    |G| <= t e^{...}, |F'| <= (d + (σ_m² cosh² u + d²/2) t) e^{...}; the interpolant's error <= 2 Σ_{j>=Q} |a_j|
    <= 4 M r^{-2Q} / (1 - r^{-2}), the best of a grid of u."""
    sm = math.sqrt(mu_max)
    tt = np.asarray(t, float)[None, :]
    ratio = max(2.0 * Q / max(float(np.max(t)) * sm, 1e-300), 1.0 + 1e-9)
    u = np.unique(np.concatenate([np.geomspace(1e-6, 3.0, 96), [math.acosh(ratio)]]))[:, None]
    base = tt * sm * np.sinh(u) - 2.0 * Q * u - np.log1p(-np.exp(-2.0 * u)) + math.log(4.0)
    log_m = (np.log1p(0.5 * d * tt) + 0 * u,                                          # F
             np.log(d + (mu_max * np.cosh(u) ** 2 + 0.5 * d * d) * tt + 1e-300),      # F'
             np.log(np.maximum(tt, 1e-300)) + 0 * u)                                   # G
    out = np.zeros((3, tt.shape[1]))
    for i, lm in enumerate(log_m):
        out[i] = np.exp(np.min(lm + base, axis=0))
    return out


def _moments(apply, start, W, mu_max, Qmax, local, stop):
    """The Chebyshev moments μ_j = W T_j(H) start (H = 2 M / mu_max - 1, ``apply`` y -> M y in two sparse products)
    for j < Qmax, or fewer where ``stop(j, ‖E_j‖ bound)`` says so: (moments (rows, Q), ‖E_j‖ bounds (Q,), ‖ŷ_j‖ (Q,)).
    The recurrence's round-off: ‖δ_j‖ <= local (‖ŷ_j‖ + ‖ŷ_{j-1}‖) per step, propagated by U_{j-i-1}(H)
    (‖U_n(H)‖ <= n + 1): ‖E_j‖ <= Σ_i (j - i) ‖δ_i‖ (:func:`tail_free_chebyshev`)."""
    mom = np.zeros((W.shape[0], Qmax))
    Eb = np.zeros(Qmax)
    ynorm = np.zeros(Qmax)
    c1, c0 = 4.0 / mu_max, 2.0 / mu_max
    y_prev = start
    mom[:, 0] = W @ y_prev
    ynorm[0] = float(np.linalg.norm(start)) * (1 + 1e-10)
    D = total = 0.0
    y = None
    for j in range(1, Qmax):
        if j == 1:
            y_new = c0 * apply(y_prev) - y_prev
            delta = local * ynorm[0]
        else:
            y_new = c1 * apply(y) - 2.0 * y - y_prev
            delta = local * (ynorm[j - 1] + ynorm[j - 2])
            y_prev = y
        y = y_new
        D += delta
        total += D
        Eb[j] = total
        ynorm[j] = float(np.linalg.norm(y)) * (1 + 1e-10)
        mom[:, j] = W @ y
        if j % 512 == 0 and stop(j, total):
            return mom[:, :j + 1], Eb[:j + 1], ynorm[:j + 1]
    return mom, Eb, ynorm


def tail_free_chebyshev(K, C, xv, times, d, mu_max, free_bound, alpha):
    """g_r(t) = c_rᵀ e^{A t} [xv; 0] at ``times`` for a uniform damping d, and its slopes, with their certified
    errors: (values, slopes, value errors, slope errors), each (rows, nodes).

    Per singular plane (σ; [u; 0], [0; u_e]) the state from [η; 0] is [F_t(σ²) η; -σ G_t(σ²) η] (:func:`_plane_functions`),
    and σ u_e = Kᵀ u, so g_r = c_v,rᵀ F_t(K Kᵀ) xv - c_e,rᵀ G_t(Kᵀ K) Kᵀ xv: two sides, each a function of one
    symmetric matrix M (K Kᵀ on xv, Kᵀ K on z = Kᵀ xv).  With H = 2 M / mu_max - 1 (spectrum in [-1, 1], mu_max >=
    ‖K‖_1 ‖K‖_∞ a power of 2: exact scalings) the moments μ_j = W T_j(H) y0 (W: the rows' parts) come from the
    three-term recurrence (:func:`_moments`); in blocks of nodes, the degree Q - 1 interpolant of f_t at Q Chebyshev
    points λ_q gives wᵀ p(H) y0 = Σ_q f_t(λ_q) m_q, m = DCT-III(μ) / Q.  Errors: the interpolant's
    (:func:`_truncation`, times ‖w‖ ‖y0‖); the recurrence's round-off ‖E_j‖, entering g times Σ_j |ĉ_j| <= (2 Q)^½
    max_q |f_t(λ_q)| (the interpolant's discrete orthogonality) and ‖w‖; the dot products (N ε ‖w‖ ‖ŷ_j‖), the
    functions' evaluation, the DCT and z's own round-off as allowances."""
    n = xv.size
    rows = C.shape[0]
    Kc = K.tocsr()
    KT = K.T.tocsr()
    nr = int(np.diff(Kc.indptr).max()) if Kc.nnz else 0
    nc = int(np.diff(KT.indptr).max()) if KT.nnz else 0
    eps = np.finfo(float).eps
    local = (4.0 * (nr + nc + 2) + 12.0) * eps * 1.01                      # ‖δ_i‖ <= local (‖ŷ_i‖ + ‖ŷ_{i-1}‖)
    sm = math.sqrt(mu_max)
    Qmax = chebyshev_degree(float(times[-1]), mu_max)

    def t_of(Q):                                                             # the time degree Q resolves
        return max(0.0, (Q - 64) * 2.0 / (1.08 * sm))
    values = np.zeros((rows, times.size))
    slopes = np.zeros((rows, times.size))
    ev = np.zeros((rows, times.size))
    es = np.zeros((rows, times.size))
    z = KT @ xv
    sides = (("v", lambda y: Kc @ (KT @ y), np.ascontiguousarray(C[:, :n]), xv),
             ("e", lambda y: KT @ (Kc @ y), np.ascontiguousarray(C[:, n:]), z))
    for side, apply, W, y0 in sides:
        wn = np.linalg.norm(W, axis=1)
        if not np.any(wn) or not np.any(y0):
            continue
        yn = float(np.linalg.norm(y0))

        def stop(j, total):                    # the moments' error already above the norm bound's share: stop
            t = t_of(j + 1)
            theta = np.pi * (np.arange(j + 1) + 0.5) / (j + 1)
            F, _, G = _plane_functions(mu_max * np.cos(0.5 * theta) ** 2, np.array([t]), d)
            fmax = float(np.abs(F if side == "v" else G).max())
            on = wn > 0
            return bool(np.all(math.sqrt(2.0 * (j + 1)) * fmax * wn[on] * total
                               > TAIL_SHARE * free_bound[on] * math.exp(-alpha * t)))
        on = wn > 0
        mom_on, Eb, ynorm = _moments(apply, y0, W[on], mu_max, Qmax, local, stop)
        mom = np.zeros((rows, mom_on.shape[1]))
        mom[on] = mom_on
        reached = mom.shape[1]
        dot = n * eps * 1.01 * ynorm                                         # per unit ‖w‖: the dot products
        a = 0
        while a < times.size:
            need = chebyshev_degree(float(times[min(a + 7, times.size - 1)]), mu_max)
            block = max(8, min(256, int(2e6 / need)))
            tb = times[a:a + block]
            need = chebyshev_degree(float(tb[-1]), mu_max)
            if need > reached:                                               # beyond the moments computed
                ev[wn > 0, a:], es[wn > 0, a:] = np.inf, np.inf
                break
            Q = need
            m = sf.dct(mom[:, :Q], type=3, axis=1) / Q
            theta = np.pi * (np.arange(Q) + 0.5) / Q
            lam = mu_max * np.cos(0.5 * theta) ** 2                          # (1 + cos θ) / 2, no cancellation
            F, Fp, G = _plane_functions(lam, tb, d)
            tr = _truncation(tb, Q, mu_max, d)                               # (F, F', G)
            # v side: value F, slope F'; e side: value -G, slope -F (G' = F)
            fv, fs, tv, ts = (F, Fp, tr[0], tr[1]) if side == "v" else (G, F, tr[2], tr[0])
            sign = 1.0 if side == "v" else -1.0
            values[:, a:a + tb.size] += sign * (m @ fv)
            slopes[:, a:a + tb.size] += sign * (m @ fs)
            mom_err = math.sqrt(2.0 * Q) * (float(Eb[:Q].max()) + float(dot[:Q].max()))
            # evaluation: f_t(λ_q) to 64 (2 + t σ_m) (1 + d t) ε of its terms, the sums over q (Q ε), the DCT
            # (10 log2 Q ε, normwise); F' has terms of O(σ_m)
            ea = 64.0 * eps * (2.0 + tb * sm) * (1.0 + d * tb) + Q * eps
            dct = 10.0 * math.log2(max(Q, 2)) * eps * math.sqrt(Q)
            s1, s2 = np.abs(m).sum(axis=1), np.linalg.norm(m, axis=1)
            for out, fn, trunc, scale in ((ev, fv, tv, 1.0), (es, fs, ts, 1.0 + d + 2.0 * sm if side == "v" else 1.0)):
                fmax = np.abs(fn).max(axis=0)
                out[:, a:a + tb.size] += np.outer(wn, trunc * yn + mom_err * fmax) + np.outer(
                    s1, ea * scale * (1.0 + fmax)) + np.outer(s2, dct * fmax)
            a += tb.size
    # z = Kᵀ xv is itself rounded: <= (n_c + 1) ε σ_m ‖xv‖, times ‖c_e‖ and |G| <= t (values), |F| <= 1 + dt (slopes)
    zr = (nc + 1) * eps * 1.01 * sm * float(np.linalg.norm(xv)) * np.linalg.norm(C[:, n:], axis=1)
    ev += np.outer(zr, times)
    es += np.outer(zr, 1.0 + d * times)
    return values, slopes, ev, es


def tail_of(planes, C, Bcols, x0, d, K=None):
    """The uncomputed planes' norms (:class:`Tail`), or None when every plane is computed.  Needs σ_cut > d / 2
    (every uncomputed plane underdamped, decaying at d / 2).  ``K`` (sparse N x N,
    :func:`sphrom.rom.planes.coupling`): the singular planes' coupling, for the weighted norms (without it, the plain ones alone)."""
    if planes.complete:
        return None
    sc = float(planes.info["sigma_cut"])
    if not sc > d / 2:
        raise ValueError(f"the computed planes end at sigma = {sc:g} s^-1, not above d / 2 = {d / 2:g} s^-1")
    S = planes.basis(np.arange(planes.count))

    def residual(X):
        return X - S @ (S.T @ X)

    def rest(X):
        R = residual(X)
        return np.linalg.norm(R, axis=0) * (1 + 1e-12) + 1e-15 * np.linalg.norm(X, axis=0)
    kappa = math.sqrt((sc + d / 2) / (sc - d / 2)) if d > 0 else 1.0
    tail = Tail(sigma_cut=sc, kappa=kappa, alpha=d / 2, inv_norm=(1.0 + d / sc) / sc, c_norm=rest(C.T),
                b_norm=rest(Bcols), x0_norm=float(rest(x0[:, None])[0]))
    if K is not None:
        import scipy.sparse as sp
        import scipy.sparse.linalg as spl
        n = K.shape[0]
        s = sc * sc
        knorm = float(abs(K).sum(axis=1).max())                 # >= σ_max
        Rc = residual(np.asarray(C, float).T)                    # (2N, rows): the rows' tail parts
        eye = sp.identity(n, format="csc")
        weighted = np.zeros(Rc.shape[1])
        for part, M in ((Rc[:n], K @ K.T), (Rc[n:], K.T @ K)):
            if np.any(part):
                lu = spl.splu((M + s * eye).tocsc())
                y = lu.solve(np.ascontiguousarray(part))
                weighted += np.einsum("ij,ij->j", part, y)
        # round-off of the solve and of the projection: 1e-10 relative, plus the rows' computed-plane residue
        tail.c_weighted = np.sqrt(np.maximum(weighted, 0.0)) * (1 + 1e-10) + 1e-15 * np.linalg.norm(C, axis=1) / sc
        r0 = residual(np.asarray(x0, float)[:, None])[:, 0]
        energy = (np.linalg.norm(K.T @ r0[:n]) ** 2 + np.linalg.norm(K @ r0[n:]) ** 2 + s * (r0 @ r0))
        tail.x0_weighted = math.sqrt(energy) * (1 + 1e-10) + 1e-15 * knorm * float(np.linalg.norm(x0))
    return tail


def floored(a, floor=SIZE_FLOOR):
    """``a`` (non-negative sizes) with its positive entries below ``floor`` raised to it (zeros and inf kept): an
    upper bound still, whose products with the decays (>= DECAY_FLOOR) the FMU forms as normal numbers (a subnormal
    operand costs ~100 cycles on x86; fmu_src/rom_bound.c BOUND_SIZE_FLOOR)."""
    a = np.asarray(a, float)
    return np.where((a > 0) & (a < floor), floor, a)


def floored_decay(x):
    """e^{-x} (x >= 0, array) at least DECAY_FLOOR (an upper bound of it; rom_bound.c floored_decay)."""
    x = np.asarray(x, float)
    return np.where(x >= DECAY_FLOOR_X, DECAY_FLOOR, np.maximum(np.exp(-np.minimum(x, DECAY_FLOOR_X)), DECAY_FLOOR))


def complement(modes: Modes, planes_L, chat, bhat, tail: Tail | None, T, *, table=True, max_nodes=MAX_NODES,
               floor=None):
    """The complement's terms (:class:`Complement`) of the modes ``modes`` (the complement's, every computed plane
    not in the shadow), their blocks ``planes_L`` with coefficients ``chat``, ``bhat`` (for D), the uncomputed
    planes ``tail``; ``T`` the scene's horizon [s] (the table spans TABLE_SPAN x T, at most ``max_nodes``
    nodes); ``floor`` (rows,) the least room of the modes left out past the table (:func:`continued_modes`)."""
    rows, m = chat.shape[0], bhat.shape[2]
    D = feedthrough(planes_L, chat, bhat) if planes_L.shape[0] else np.zeros((rows, m))
    alphas = list(modes.alpha) + ([tail.alpha] if tail is not None else [])
    rates, group = group_rates(np.asarray(alphas))
    G = max(rates.size, 1)
    if rates.size == 0:
        rates = np.zeros(1)
    gain = np.zeros((rows, m, G))
    mg = mode_gains(modes)                                      # (rows, M, m)
    for g in range(G):
        sel = group[:modes.alpha.size] == g
        if np.any(sel):
            gain[:, :, g] = mg[:, sel].sum(axis=1)
    static = np.zeros((rows, m))
    tail_free = np.zeros(rows)
    if tail is not None:
        gt = group[-1]
        gain[:, :, gt] += tail.gain()
        static += tail.static()
        tail_free = tail.free()
    gain = floored(np.where(np.isfinite(gain), gain * (1 + SUM_ROUNDOFF), np.inf))
    if table and (np.any(np.abs(modes.P)) or np.any(tail_free)):
        t_end, h, values, slopes, errors, q, tl, cmu, cq = free_table(
            modes, group[:modes.alpha.size], rates, T, tail_free, tail.alpha if tail is not None else 0.0,
            exact=tail.exact if tail is not None else None, max_nodes=max_nodes, floor=floor)
    else:
        t_end, h, values, slopes, errors, q = 0.0, 0.0, None, None, None, 1
        cmu, cq = None, None
        tl = np.zeros((rows, G))
        hold = np.abs(modes.P)
        for g in range(G):
            sel = group[:modes.alpha.size] == g
            tl[:, g] = hold[:, sel].sum(axis=1)
        if tail is not None:
            tl[:, group[-1]] += tail_free
    return Complement(D=D, static=static * (1 + SUM_ROUNDOFF), rates=rates, gain=gain, h=float(h), values=values,
                      slopes=slopes, errors=errors, q=int(q), t_end=float(t_end), tail=floored(tl * (1 + SUM_ROUNDOFF)),
                      cont_mu=cmu, cont_Q=cq)


def table_step(modes: Modes, T, tail_alpha=None, max_nodes=MAX_NODES):
    """(t_end, h, nodes): the free response table's span and node spacing.  The span: TABLE_SPAN x T, shorter where
    every mode (and the uncomputed planes) has decayed below 1e-14 of its start; the spacing resolves the modes
    that matter (|μ| h <= NODE_RESOLUTION for every mode above 1e-12 of the largest) with at most ``max_nodes``
    nodes (:func:`choose_planes` chooses it, :data:`TABLE_NODES`); a finer table than MAX_NODES nodes, which the
    sizing takes for its interpolation error alone, resolves them to FINE_RESOLUTION."""
    size = np.abs(modes.P).max(axis=0) if modes.P.size else np.zeros(0)
    t_end = TABLE_SPAN * float(T)
    alphas = list(modes.alpha[size > 0]) + ([tail_alpha] if tail_alpha is not None else [])
    if alphas and min(alphas) > 0:
        t_end = min(t_end, math.log(1e14) / min(alphas))
    big = size > 1e-12 * max(float(size.max()), 1e-300) if size.size else size.astype(bool)
    omega = float(np.max(np.abs(modes.mu[big]))) if np.any(big) else 0.0
    resolution = NODE_RESOLUTION if max_nodes <= MAX_NODES else FINE_RESOLUTION
    nodes = int(min(max_nodes, max(2, math.ceil(t_end * omega / resolution) + 1)))
    return t_end, t_end / (nodes - 1), nodes


def free_table(modes: Modes, group, rates, T, tail_free, tail_alpha, exact: TailTable | None = None,
               max_nodes=MAX_NODES, floor=None):
    """The complement's free response g_r(t) = Re Σ_M P_rM e^{μ_M t} (per unit initial_state_scale, module
    docstring), tabulated for a cubic Hermite interpolation with a certified error: (t_end, h, values (rows, n),
    slopes (rows, n) [per s], errors (rows, n_blocks), q, tail (rows, G), cont_mu (M_c,), cont_Q (rows, M_c)).

    Nodes t_k = k h over [0, t_end] (:func:`table_step`).  The exact normal modes with |μ| h <= 1 are summed at the
    nodes (value and slope); on [t_k, t_k+1] the Hermite cubic of a sum of such modes is within Σ |P| e^{-α t_k}
    (|μ| h)^4 / 384 of it (h^4 / 384 times the sup of the fourth derivative) where |μ| h <= INTERPOLATED; every
    other mode (faster, or
    defective) counts by its size |P| e^{-α t_k}, the planes never computed by κ ‖c_tail‖ ‖x0_tail‖
    e^{-α_tail t_k}, and 1e-13 of the modes' sizes covers the nodes' round-off.  errors[r, B]: the largest over the
    intervals k of block B (k // q == B).  Beyond t_end the modes that matter (:func:`continued_modes`) are continued
    exactly, Re Σ cont_Q_rM e^{μ_M (t - t_end)} with cont_Q = P e^{μ t_end}, and the rest is bounded by its size,
    Σ_g tail_rg e^{-α_g (t - t_end)} (the tail holds only the modes left out).

    With ``exact`` (:class:`TailTable`) the uncomputed planes' free response is computed, not bounded, over its
    span: the table takes its nodes, adds its values and slopes, and its interpolation errors replace the planes'
    norm bound (which stays beyond the table's end).  ``floor`` (rows,): the least room of the modes left out past
    the table (:func:`continued_modes`)."""
    rows = modes.P.shape[0]
    if exact is not None:
        t_end, h, nodes = exact.t_end, exact.h, exact.values.shape[1]
    else:
        t_end, h, nodes = table_step(modes, T, tail_alpha if np.any(tail_free) else None, max_nodes)
    t = np.arange(nodes) * h
    ex = modes.exact & (np.abs(modes.mu) * h <= INTERPOLATED)
    lo, rest = np.flatnonzero(ex), np.flatnonzero(~ex)
    mu_lo, P_lo = modes.mu[lo], modes.P[:, lo]
    values = np.zeros((rows, nodes))
    slopes = np.zeros((rows, nodes))
    bound = np.zeros((rows, nodes - 1))
    size_lo, size_rest = np.abs(P_lo), np.abs(modes.P[:, rest])
    size_all = np.abs(modes.P)
    for start in range(0, nodes, 2048):
        tt = t[start:start + 2048]
        if lo.size:
            E = np.exp(np.outer(mu_lo, tt))
            values[:, start:start + tt.size] = np.real(P_lo @ E)
            slopes[:, start:start + tt.size] = np.real((P_lo * mu_lo[None, :]) @ E)
        tk = tt[:min(tt.size, nodes - 1 - start)]
        if tk.size == 0:
            continue
        err = np.zeros((rows, tk.size))
        if lo.size:
            err += size_lo @ (np.exp(-np.outer(modes.alpha[lo], tk)) * ((np.abs(mu_lo) * h) ** 4 / 384.0)[:, None])
        if rest.size:
            err += size_rest @ np.exp(-np.outer(modes.alpha[rest], tk))
        if size_all.size:
            err += 1e-13 * (size_all @ np.exp(-np.outer(modes.alpha, tk)))
        if exact is not None:
            err += exact.error[:, start:start + tk.size]
        elif np.any(tail_free):
            err += np.outer(tail_free, np.exp(-tail_alpha * tk))
        bound[:, start:start + tk.size] = err
    if exact is not None:
        values += exact.values
        slopes += exact.slopes
    q = max(1, int(math.ceil((nodes - 1) / N_BLOCKS)))
    blocks = int(math.ceil((nodes - 1) / q))
    errors = np.zeros((rows, blocks))
    for B in range(blocks):
        errors[:, B] = bound[:, B * q:(B + 1) * q].max(axis=1)
    G = rates.size
    tail = np.zeros((rows, G))
    decayed = np.abs(modes.P) * np.exp(-modes.alpha * t_end)[None, :]
    free_end = tail_free * math.exp(-tail_alpha * t_end) if np.any(tail_free) else np.zeros(rows)
    cont = continued_modes(modes, decayed, errors.max(axis=1) if errors.size else np.zeros(rows), values, free_end,
                           floor)
    for g in range(G):
        tail[:, g] = decayed[:, (group == g) & ~cont].sum(axis=1)
    if np.any(tail_free):
        gt = int(np.searchsorted(rates, tail_alpha * (1 + 1e-9) + 1e-300, side="right") - 1)
        tail[:, max(gt, 0)] += free_end
    cont_mu = modes.mu[cont].astype(complex)
    cont_Q = modes.P[:, cont].astype(complex) * np.exp(cont_mu * t_end)[None, :]
    return (t_end, h, values, slopes, errors * (1 + SUM_ROUNDOFF), q, tail * (1 + SUM_ROUNDOFF), cont_mu,
            cont_Q)


def continued_modes(modes: Modes, decayed, budget, values, fixed, floor=None):
    """(M,) bool: the exact normal modes whose free response is continued past the table's end (added exactly,
    :func:`free_part`) rather than bounded by its size there, ``decayed`` (rows, M) = |P_rM| e^{-α_M t_end}.

    Per row r, the modes left out keep their Hölder sum Σ |P_rM| e^{-α_M t_end} (with ``fixed`` (rows,), the size
    left out whatever is chosen: the defective modes' and the planes never computed) within the allowance the table's
    own error was sized to (:func:`choose_planes`: ``budget`` (rows,), the table's largest certified error, or
    FREE_TARGET x the row's largest tabulated free response where that is larger): the bound's free part past the
    table is then no larger than within it.  Or within ``floor`` (rows,) where that is larger (:func:`build_shadow`):
    :data:`CONT_SHARE` of the round-off allowance the bound carries at every time, ROUNDOFF ‖c_r‖ ‖x0‖ per unit
    initial_state_scale (:func:`run_shadow`, the C core's), so that past the table the bound exceeds the one with
    every such mode continued by at most CONT_SHARE x that allowance: a complement whose free response is round-off
    (the initial state's coefficients on the planes left out of an accurate shadow: high_frequency's; tests/
    test_bound_step_cost.py test_round_off_complement_is_not_continued_past_the_table) is not continued mode by mode (each costs the FMU a complex product and its sums per step); and
    where the model's own error from its initial state is known (:func:`choose_planes`, ``model_runs``), the free
    channel's allowance of it, MODEL_FRACTION x that error: past the table the bound's free part stays within the
    allowance the channel was sized to, as within it (the table is finer than that allowance asks: more nodes cost
    nothing per step), so the bound of a model less accurate than the table stays within 1 + 2 MODEL_FRACTION of
    its largest error from its initial state.  The smallest modes are left out first; a mode is continued where any
    row needs it."""
    M = decayed.shape[1]
    cont = np.zeros(M, bool)
    if M == 0:
        return cont
    fixed = np.asarray(fixed, float) + decayed[:, ~modes.exact].sum(axis=1)
    scale = np.abs(values).max(axis=1) if values is not None and values.size else np.zeros(decayed.shape[0])
    room = np.maximum(np.asarray(budget, float), FREE_TARGET * scale)
    if floor is not None:
        room = np.maximum(room, np.asarray(floor, float))
    room = np.maximum(room - fixed, 0.0)
    candidate = modes.exact & np.all(np.isfinite(decayed), axis=0) & np.any(decayed > 0, axis=0)
    idx = np.flatnonzero(candidate)
    for r in range(decayed.shape[0]):
        d = decayed[r, idx]
        order = np.argsort(d, kind="stable")
        left = np.cumsum(d[order]) <= room[r]                 # the smallest, while their sum stays within the room
        cont[idx[order[~left]]] = True
    return cont


def cont_roundoff(comp: Complement, tau, steps=0, drift=0.0):
    """(rows,) the round-off allowance of the continued modes' sum at ``tau`` > t_end [s] (:func:`free_part`; the C
    core's, fmu_src/rom_bound.c, derives it above cont_exact), ``steps`` steps after the exponentials
    e^{μ_M (τ - t_end)} were computed exactly (the FMU carries them over the steps, e^{μ h} per step, anchored
    exactly every :data:`CONT_ANCHOR` steps; 0: computed exactly, as here), ``drift`` [s] the state's time off the
    steps' exact sum since then (the sum of each step's rounding of τ + h; at most ``steps`` ε τ):
    1.01 [Σ_M q_rM (CONT_ROUNDOFF + (M_c + 8 + 12 n) ε) + Σ_M q_rM a_M (4 ε τ + D)], q_rM = |Re Q_rM| + |Im Q_rM|,
    a_M = |Re μ_M| + |Im μ_M|, n = ``steps``, D = ``drift``, ε = 2^-53 (with |e^{μ x}| <= 1: O(1) per row in the
    FMU); infinite where (12 n + 4 max_M a_M τ) ε + max_M a_M D > 1e-3."""
    if comp.cont_mu is None or comp.cont_mu.size == 0:
        return np.zeros(comp.tail.shape[0])
    eps = 2.0 ** -53
    n = float(steps)
    q = np.abs(comp.cont_Q.real) + np.abs(comp.cont_Q.imag)
    a = np.abs(comp.cont_mu.real) + np.abs(comp.cont_mu.imag)
    if not (12 * n + 4 * a.max() * tau) * eps + a.max() * drift <= 1e-3:
        return np.full(q.shape[0], np.inf)
    k0 = 1.01 * (CONT_ROUNDOFF + (comp.cont_mu.size + 8 + 12 * n) * eps)
    k1 = 1.01 * (4 * eps * tau + drift)
    return k0 * q.sum(axis=1) + k1 * (q @ a)


# ---------------------------------------------------------------------------------------------------------------
# a parametric shadow's complement at (c, d)
# ---------------------------------------------------------------------------------------------------------------

def parametric_complement(cp, c_ref, c, d):
    """The complement's terms at (c, d) of a parametric shadow's complement planes ``cp`` (sigma (n,), chat
    (rows, n, 2) at c_ref, bv (n, m), eta (n,)): per plane the block [[-d, σ̃], [-σ̃, 0]] in the energy
    coordinates of c (σ̃ = sqrt(c / c_ref) σ, the e coefficients of a row times sqrt(c_ref / c)), its modes in
    normal form (:func:`sphrom.rom.planes.plane_modes`), two groups (the underdamped planes at d / 2, the others at
    the slowest rate among them), the initial state by the modes' decaying Hölder sums (no table).  The C core
    (fmu_src/rom_bound.c) does the same arithmetic."""
    sig = np.asarray(cp["sigma"], float)
    chat = np.array(cp["chat"], float)
    bv = np.asarray(cp["bv"], float)
    eta = np.asarray(cp["eta"], float)
    rows, n, m = chat.shape[0], sig.size, bv.shape[1]
    st = math.sqrt(c / c_ref) * sig
    chat[:, :, 1] *= math.sqrt(c_ref / c)
    L = np.zeros((n, 2, 2))
    L[:, 0, 0], L[:, 0, 1], L[:, 1, 0] = -d, st, -st
    bhat = np.zeros((n, 2, m))
    bhat[:, 0, :] = bv
    et = np.zeros((n, 2))
    et[:, 0] = eta
    modes = plane_modes(L, chat, bhat, et)
    D = feedthrough(L, chat, bhat) if n else np.zeros((rows, m))
    under = (modes.alpha >= d / 2 * (1 - 1e-12)) & modes.exact & (np.imag(modes.mu) != 0)
    slow = float(np.min(modes.alpha[~under])) if np.any(~under) else d / 2
    rates = np.array([d / 2, min(slow, d / 2)])
    gain = np.zeros((rows, m, 2))
    mg = mode_gains(modes)
    gain[:, :, 0] = mg[:, under].sum(axis=1)
    gain[:, :, 1] = mg[:, ~under].sum(axis=1)
    tail = np.zeros((rows, 2))
    tail[:, 0] = np.abs(modes.P[:, under]).sum(axis=1)
    tail[:, 1] = np.abs(modes.P[:, ~under]).sum(axis=1)
    return Complement(D=D, static=np.zeros((rows, m)), rates=rates,
                      gain=floored(np.where(np.isfinite(gain), gain * (1 + SUM_ROUNDOFF), np.inf)), h=0.0,
                      values=None, slopes=None, errors=None, q=1, t_end=0.0,
                      tail=floored(tail * (1 + SUM_ROUNDOFF)))


# ---------------------------------------------------------------------------------------------------------------
# construction
# ---------------------------------------------------------------------------------------------------------------

def decompose(problem, parametric=False, count=None):
    """The planes of ``problem`` (:mod:`.planes`): singular planes for a uniform d, eigen-planes otherwise."""
    d = np.asarray(problem.d, float)
    if np.all(d == d[0]):
        return singular_planes(problem, count=count or SPARSE_PLANES, parametric=parametric)
    if parametric:
        raise ValueError("a parametric shadow needs uniform c and d")
    return eigen_planes(problem)


def reference_responses(L, chat, bhat, T, omega, series=False):
    """(step (rows, m), sine (rows, m)): the largest |y_r| of the response to a unit step and to a unit sine of
    ``omega`` [s^-1] on input j over [0, T] (held over REFERENCE_STEPS steps; every computed plane, exact in
    time), the channel scales of :func:`choose_planes`.  ``series``: also the responses themselves, a list per
    reference input of (rows, m, REFERENCE_STEPS) arrays, y after each step (what a model's own runs are
    compared with, :func:`model_errors`)."""
    n, m = L.shape[0], bhat.shape[2]
    rows = chat.shape[0]
    steps = REFERENCE_STEPS
    h = T / steps
    t = np.arange(steps) * h
    out, runs = [], []
    for u in (np.ones(steps), np.sin(omega * t)):
        M = np.zeros((n, 4, 4))
        M[:, :2, :2] = L * h
        M[:, 3, 3] = 0.0
        M[:, 2, 3] = 0.0
        res = np.zeros((rows, m))
        ys = np.zeros((rows, m, steps)) if series else None
        for j in range(m):
            M[:, :2, 2] = bhat[:, :, j] * h
            E = sla.expm(M)
            Phi, g0 = E[:, :2, :2], E[:, :2, 2]
            z = np.zeros((n, 2))
            peak = np.zeros(rows)
            for k in range(steps):
                z = np.einsum("nij,nj->ni", Phi, z) + g0 * u[k]
                y = np.einsum("rni,ni->r", chat, z)
                peak = np.maximum(peak, np.abs(y))
                if series:
                    ys[:, j, k] = y
            res[:, j] = peak
        out.append(res)
        runs.append(ys)
    return (out[0], out[1], runs) if series else (out[0], out[1])


def sine_variation(alpha, omega, span):
    """The weighted variation of the unit reference sine of ``omega`` [s^-1] over ``span`` [s] for a decay rate
    alpha [s^-1] (an array or a number): ω min(span, 1/α) + 1 (1/α infinite where α <= 0)."""
    alpha = np.asarray(alpha, float)
    return omega * np.minimum(span, np.where(alpha > 0, 1.0 / np.maximum(alpha, 1e-300), np.inf)) + 1.0


def probe_density(e, pw, prho0):
    """ρ at a probe from e at its two particles: Σ_m pw_m ρ0_m / (1 + e_m) over the last axis (e (..., 2))."""
    return np.sum(pw * prho0 / (1.0 + e), axis=-1)


def reference_omega(planes):
    """The reference sine's angular frequency [s^-1]: half the first elastic frequency (:func:`choose_planes`)."""
    L = planes.blocks[0]
    key = planes.key
    # the first elastic frequency: the slowest plane that oscillates (σ of a singular plane [[-d, σ], [-σ, 0]], ω of a
    # complex pair [[-α, ω], [-ω, -α]]); a plane of real modes (the rigid motion decaying at a damping that varies
    # along the bar, |λ| ~ d) does not, and taking its |λ| put the reference sine near 0 Hz
    freq = 0.5 * np.abs(L[:, 0, 1] - L[:, 1, 0])
    elastic = freq[freq > 1e-9 * max(float(freq.max(initial=0.0)), 1e-300)]
    if not elastic.size:                                       # (a parametric shadow's constant piece): the key
        elastic = key[key > 1e-9 * max(float(key[-1]), 1e-300)]
    return 0.5 * float(elastic.min()) if elastic.size else 1.0


def model_errors(model_runs, truth_step, truth_sine, truth_free, omega, T, P, pw, prho0, strain=1e-4):
    """The model's own error on the reference inputs, per shadow row (NaN where not measured): (step (rows, m),
    sine (rows, m), free (rows,)), from ``model_runs(h, f, scale)`` -> (v (steps, P), ρ (steps, P)) or (v, ρ,
    v_port (steps, ports)), the model's outputs after each of len(f) steps of h [s] under the force f held over each
    step [m s^-2] (no port force), from rest (scale 0) or from its initial state (scale 1; then with the outputs at
    t = 0 first).  The truth: the full
    linear SPH's series of :func:`reference_responses` (unit inputs) and the free response ``truth_free`` (rows,
    FREE_SAMPLES + 1) over TABLE_SPAN x T.  Velocity rows: |v_model - v_true|; the two e rows of a probe: its
    density's error over Σ_m pw_m ρ0_m (dρ/de at e = 0); port rows: |v_port_model - v_port_true| where the runs
    give v_port, else NaN (sized by the target alone); port inputs: NaN.  The force channel only (input 0), its reference inputs scaled down where the truth's largest |e| under
    a unit input passes ``strain`` (a model whose density is not linear in e, the frozen one, is compared where the
    truth's linearity in J and its own agree), the errors per unit input."""
    rows, m, steps = truth_step.shape
    step_e = np.full((rows, m), np.nan)
    sine_e = np.full((rows, m), np.nan)
    free_e = np.full(rows, np.nan)
    rho_scale = (pw * prho0).sum(axis=1)                        # (P,)

    def errors(v, rho, y, v_port=None):
        """per row: the largest error of the model's (v, ρ) (M, P) and v_port (M, ports) against the truth's rows y
        (rows, M)"""
        out = np.full(rows, np.nan)
        out[:P] = np.abs(v - y[:P].T).max(axis=0)
        if v_port is not None and rows > 3 * P:
            out[3 * P:] = np.abs(np.asarray(v_port, float).reshape(y.shape[1], -1) - y[3 * P:].T).max(axis=0)
        for j in range(P):
            e = y[P + 2 * j:P + 2 * j + 2].T                     # (M, 2)
            rho_t = probe_density(e, pw[j], prho0[j])
            out[P + 2 * j:P + 2 * j + 2] = np.abs(rho[:, j] - rho_t).max() / rho_scale[j]
        return out

    h = T / steps
    t = np.arange(steps) * h
    for f, truth, into in ((np.ones(steps), truth_step, step_e), (np.sin(omega * t), truth_sine, sine_e)):
        top = float(np.max(np.abs(truth[P:3 * P, 0, :]), initial=0.0))
        a = min(1.0, strain / top) if top > 0 else 1.0
        got = model_runs(h, a * f, 0.0)
        into[:, 0] = errors(np.asarray(got[0]), np.asarray(got[1]), a * truth[:, 0, :], *got[2:3]) / a
    n_free = truth_free.shape[1] - 1
    got = model_runs(TABLE_SPAN * T / n_free, np.zeros(n_free), 1.0)
    free_e[:] = errors(np.asarray(got[0]), np.asarray(got[1]), truth_free, *got[2:3])
    return step_e, sine_e, free_e


def _row_classes(P, n_ports):
    """The row classes a criterion compares within: v probes, e rows, ports."""
    out = [np.arange(P), np.arange(P, 3 * P)]
    if n_ports:
        out.append(np.arange(3 * P, 3 * P + n_ports))
    return out


def choose_planes(planes, modes_all, chat, bhat, eta, tail_fn, T, P, n_ports, *, target=SHADOW_TARGET,
                  max_planes=MAX_PLANES, at_least=1, table=True, model_runs=None, pw=None, prho0=None,
                  contiguous=False):
    """The smallest number of planes (a gap cut, >= ``at_least``) whose certified complement stays below each
    channel's allowance (module docstring): per input j, a unit step (the transient's gains, its variation 1) and a
    unit sine at half the first elastic frequency over REFERENCE_SPAN x T (the gains times its weighted variation
    ω min(span, 1/α) + 1, plus the quasi-static tail), each against the largest response of its row class; the
    initial state: its free response table's error at t = 0 (``table``; else, a parametric shadow's, the
    complement's Hölder sum) against the largest free response.

    A channel's allowance is ``target`` x its response (the initial state's, with a table: FREE_TARGET x it), or,
    where the model's own error on that reference input is known (``model_runs``, :func:`model_errors`) and larger,
    MODEL_FRACTION x that error: the bound is at most the error plus twice the complement's, so its effectivity on
    the reference inputs stays below 1 + 2 MODEL_FRACTION, and a more accurate model gets at least as many planes;
    an unknown error (port rows, ``model_runs`` None) counts as 0, so that such a shadow gets at least as many planes
    as any known model's.  Returns (planes, criterion value per cut (the
    complement against the responses), the responses and, under "excess", the largest complement / allowance of
    each cut tried, and under "table_nodes" the free response table's nodes at most: :func:`complement`'s
    ``max_nodes``)."""
    n = planes.count
    rows, m = chat.shape[0], bhat.shape[2]
    key = planes.key
    L = planes.blocks[0]
    omega = reference_omega(planes)
    if model_runs is not None:
        step_r, sine_r, runs = reference_responses(L, chat, bhat, T, omega, series=True)
    else:
        step_r, sine_r = reference_responses(L, chat, bhat, T, omega)
    classes = _row_classes(P, n_ports)
    span = REFERENCE_SPAN * T
    t = np.linspace(0.0, TABLE_SPAN * T, FREE_SAMPLES + 1)
    mg = mode_gains(modes_all)                                 # (rows, M, m)
    free_all = np.real(modes_all.P @ np.exp(np.outer(modes_all.mu, t)))   # the whole free response (all modes)
    free_scale = np.abs(free_all).max(axis=1)
    big = [max(float(step_r[cls].max()), float(sine_r[cls].max()), float(free_scale[cls].max()) if np.any(eta)
               else 0.0) for cls in classes]             # a channel this far below a class's largest: not judged
    step_e = sine_e = free_e = None
    model_info = None
    if model_runs is not None:
        try:
            step_e, sine_e, free_e = model_errors(model_runs, runs[0], runs[1], free_all, omega, T, P, pw, prho0)
            if not (np.all(np.isfinite(step_e[:3 * P, 0])) and np.all(np.isfinite(free_e[:3 * P]))):
                raise ValueError("the model's reference runs are not finite")
            model_info = {"step": float(np.nanmax(step_e[:P, 0])), "sine": float(np.nanmax(sine_e[:P, 0])),
                          "free": float(np.nanmax(free_e[:P]))}
        except Exception as exc:                               # (a model the core cannot run so): the target alone
            step_e = sine_e = free_e = None
            model_info = {"failed": str(exc).splitlines()[0] if str(exc) else type(exc).__name__}
    # the planes in clusters of one frequency (a degenerate pair is kept or left together, planes.gap_cuts).  The
    # shadow keeps a prefix of an order of the clusters: the lowest first (the planes below at_least always), or
    # the clusters by their largest complement term against target x the channel's response (the planes that
    # matter whatever their frequency: a force profile with a short wavelength reaches a high plane and few below
    # it); the smaller of the two shadows that meet the allowances
    edges = [0] + [c for c in gap_cuts(key) if c < n] + [n]
    clusters = [np.arange(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]
    forced = [i for i, c in enumerate(clusters) if c[0] < at_least]
    lowest = [i for i, c in enumerate(clusters) if c[0] >= at_least]
    orders = [forced + lowest]
    if not contiguous:
        h_all = table_step(modes_all, T, None)[1] if table else 0.0
        importance = cluster_importance(clusters, modes_all, mg, omega, span, classes, step_r, sine_r, free_scale,
                                        big, np.any(eta), h_all)
        orders.append(forced + sorted(lowest, key=lambda i: (-importance[i], i)))

    def allowance(scale, err, floor=target):
        """the complement a channel may have: ``floor`` x its response, or MODEL_FRACTION x the model's error on it
        where that is known and larger.  One rule whether or not the error is known: an unknown error (a port row
        the runs do not give, a model the core cannot run so, a shadow sized on the target alone) counts as 0, the
        error of a perfect model, so such a row gets the tightest allowance, never a looser one than a known accurate
        model's"""
        if err is None or not np.isfinite(err):
            return floor * scale
        return max(floor * scale, MODEL_FRACTION * float(err))

    # the free channel's floor: its complement's part is the table's interpolation error, which more nodes shrink at
    # no cost per step, so that a model more accurate than target x the free response from its initial state
    # (multimode's exact model: 2e-7 of it) keeps its effectivity there below 1 + 2 MODEL_FRACTION (where its error
    # is above FREE_TARGET x the response) instead of target x response / its error.  The same floor where the error
    # is not known (port rows the runs do not give, a shadow sized on the target alone): such a model may be that
    # accurate too
    free_floor = min(target, FREE_TARGET) if table else target

    def value(keep, max_nodes=MAX_NODES):
        """(the largest complement / response over the channels, the largest complement / allowance) with the
        planes ``keep`` kept and a free response table of at most ``max_nodes`` nodes"""
        rest = ~np.isin(modes_all.plane, keep)
        tl = tail_fn()
        worst, excess = 0.0, 0.0

        def judge(val, cls, scale, err, floor=target):
            nonlocal worst, excess
            for r in cls:
                allowed = allowance(scale, None if err is None else err[r], floor)
                excess = max(excess, float(val[r]) / allowed if allowed > 0 else np.inf)
            worst = max(worst, float(val[cls].max()) / scale)

        # each mode's variation at its group's rate, as the C core weighs it (complement: the groups of the modes
        # left out, a group's rate the smallest of its members'), so that the criterion is the bound's own term
        alphas = np.concatenate([modes_all.alpha[rest], [tl.alpha] if tl is not None else []])
        rates, group = group_rates(alphas)
        slow = rates[group] if rates.size else alphas
        for j in range(m):
            g = mg[:, rest, j]
            trans = g.sum(axis=1)
            sine = (g * sine_variation(slow[:g.shape[1]], omega, span)[None, :]).sum(axis=1)
            if tl is not None:
                extra = tl.gain()[:, j]
                trans = trans + extra
                sine = sine + extra * float(sine_variation(slow[-1], omega, span)) + tl.static()[:, j]
            for c, cls in enumerate(classes):
                for val, scale, err in ((trans, step_r[cls, j].max(), None if step_e is None else step_e[:, j]),
                                        (sine, sine_r[cls, j].max(), None if sine_e is None else sine_e[:, j])):
                    if scale > FLOOR * big[c]:
                        judge(val, cls, scale, err)
        if np.any(eta):                                        # the free response table's error at t = 0
            h_tab = table_step(_select(modes_all, rest), T, tl.alpha if tl is not None else None, max_nodes)[1]
            size = np.abs(modes_all.P[:, rest])
            interp = (modes_all.exact & (np.abs(modes_all.mu) * h_tab <= INTERPOLATED))[rest] if table else \
                np.zeros(int(rest.sum()), bool)
            err = size[:, ~interp].sum(axis=1) + size[:, interp] @ ((np.abs(modes_all.mu[rest][interp]) * h_tab)
                                                                     ** 4 / 384.0)
            if tl is not None:
                err = err + tl.free()                          # the planes never computed
            for c, cls in enumerate(classes):
                scale = free_scale[cls].max()
                if scale > FLOOR * big[c]:
                    judge(err, cls, scale, free_e, free_floor)
        return worst, excess

    # the free response's table: the complement's free response is exact at its nodes, its error the cubic
    # Hermite interpolant's, h^4 / 384 sup |g^(4)| <= Σ |P| e^{-α t_k} (|μ| h)^4 / 384 over the modes on each
    # interval (free_table, certified for any h), so h^4: a finer table
    # leaves out the planes only the initial state reaches (an undamped bar's: gaussian, heterogeneous) at no
    # cost per step (one interval's values and slopes are read whatever the nodes).  The node caps tried: those of
    # TABLE_NODES within TABLE_VALUES values per row set; the fewest planes, then the fewest nodes
    caps = [MAX_NODES]
    if table and np.any(eta) and tail_fn() is None:
        caps = sorted({c for c in TABLE_NODES if c * rows <= TABLE_VALUES} | {MAX_NODES})

    def search(cap):
        """(planes kept, values, excesses, reached, plateau) of the two orders' smallest prefix, the table's nodes
        at most ``cap``"""
        values, excesses = {}, {}                              # per number of planes kept (both orders)
        found = []
        for order in orders:
            sizes = np.cumsum([clusters[i].size for i in order])
            counts = [c for c in range(max(len(forced), 1), len(order) + 1)
                      if sizes[c - 1] <= max(max_planes, at_least)]
            if not counts:
                counts = [max(len(forced), 1)]
            tried = {}

            def at(count):
                if count not in tried:
                    keep = np.sort(np.concatenate([clusters[i] for i in order[:count]]))
                    tried[count] = (keep, *value(keep, cap))
                return tried[count][2]

            lo, hi = 0, len(counts) - 1
            best = at(counts[hi])
            reached = best <= 1.0
            limit = 1.0 if reached else PLATEAU * best         # out of reach: where it levels off
            if at(counts[0]) <= limit:
                chosen = counts[0]
            else:
                while lo < hi:                                 # bisection: the criterion falls with each cluster
                    mid = (lo + hi) // 2
                    if at(counts[mid]) <= limit:
                        hi = mid
                    else:
                        lo = mid + 1
                chosen = counts[lo]
            for keep, raw, exc in tried.values():
                values.setdefault(int(keep.size), raw)
                excesses.setdefault(int(keep.size), exc)
            found.append((not reached, tried[chosen][0].size, tried[chosen][0], float(tried[counts[-1]][1]),
                          reached))
        _, _, keep, plateau, reached = min(found, key=lambda x: (x[0], x[1]))   # (ties: the lowest planes)
        if reached and not contiguous:
            # a prefix keeps clusters the allowances do not need (the importance order ranks by the largest term of
            # any row, the allowance binds on one): leave out each kept cluster, least important first, while every
            # allowance still holds.  The bound holds for any set s of planes: y = cᵀ V_s w + D u(t⁻) + s g + R
            # (module docstring) splits A's invariant planes, each z_i (i ∉ s) written on its own, so D, g and the
            # gains of R are sums over whichever planes are left out; this changes the bound's size, not its
            # validity (the C core steps any set of planes: SHLAM, SHB, SHC carry the kept ones)
            rank = {i: r for r, i in enumerate(orders[-1])}
            kept = [i for i in orders[-1] if i not in forced and np.isin(clusters[i], keep).all()]
            for i in sorted(kept, key=lambda i: -rank[i]):
                trial = np.setdiff1d(keep, clusters[i])
                if trial.size and value(trial, cap)[1] <= 1.0:
                    keep = trial
            raw, exc = value(keep, cap)
            values[int(keep.size)], excesses[int(keep.size)] = raw, exc
        return keep, values, excesses, reached, plateau

    results = [(cap, *search(cap)) for cap in caps]
    cap, keep, values, excesses, reached, plateau = min(results, key=lambda x: (not x[4], x[1].size, x[0]))
    if reached and cap > MAX_NODES:
        # the fewest nodes that still meet every allowance with these planes (the table's error falls like h^4:
        # bisection; the FMU carries rows x nodes x 2 values)
        lo, hi = MAX_NODES, cap
        while hi - lo > max(64, lo // 64):
            mid = (lo + hi) // 2
            if value(keep, mid)[1] <= 1.0:
                hi = mid
            else:
                lo = mid
        cap = hi
    # past the table the modes left out may reach the free channel's allowance where the model's error gave it
    # (continued_modes): MODEL_FRACTION x the model's error from its initial state, per row (0 where not known)
    model_room = np.zeros(rows) if free_e is None else MODEL_FRACTION * np.nan_to_num(np.asarray(free_e, float))
    return keep, values, {"omega_ref": omega, "reached": bool(reached), "plateau": plateau,
                          "excess": excesses, "model_error": model_info, "table_nodes": int(cap),
                          "free_model_room": [float(x) for x in model_room]}


def cluster_importance(clusters, modes, mg, omega, span, classes, step_r, sine_r, free_scale, big, initial, h_tab):
    """Each cluster's largest complement term against its channel's response (:func:`choose_planes`): per mode the
    step's gain, the sine's gain times its weighted variation, the free response's size (|P|; times the table's
    interpolation factor (|μ| h_tab)^4 / 384 for a mode the table interpolates, h_tab > 0), per row class against
    the class's largest reference response (channels below FLOOR of the class's largest not judged)."""
    vs = sine_variation(modes.alpha, omega, span)
    per_mode = np.zeros(modes.plane.size)
    m = mg.shape[2]
    size = np.abs(modes.P)
    if h_tab > 0:
        interp = modes.exact & (np.abs(modes.mu) * h_tab <= INTERPOLATED)
        size = np.where(interp[None, :], size * (np.abs(modes.mu) * h_tab) ** 4 / 384.0, size)
    for c, cls in enumerate(classes):
        for j in range(m):
            for g, scale in ((mg[cls, :, j], step_r[cls, j].max()), (mg[cls, :, j] * vs[None, :],
                                                                     sine_r[cls, j].max())):
                if scale > FLOOR * big[c]:
                    per_mode = np.maximum(per_mode, g.max(axis=0) / scale)
        scale = free_scale[cls].max()
        if initial and scale > FLOOR * big[c]:
            per_mode = np.maximum(per_mode, size[cls].max(axis=0) / scale)
    out = np.zeros(len(clusters))
    for i, planes in enumerate(clusters):
        sel = np.isin(modes.plane, planes)
        out[i] = float(per_mode[sel].max()) if np.any(sel) else 0.0
    return out


def build_shadow(problem, probes, ports=(), *, parametric=False, scale_v=None, force=None, T=None,
                 target=SHADOW_TARGET, order=None, max_planes=MAX_PLANES, port_inputs=True, count=None,
                 tail_response=True, model_runs=None, truth=None):
    """The certified shadow of the FMUs of ``problem`` at ``probes`` (and ``ports``) (module docstring).

    Parameters
    ----------
    problem : SPHProblem
        The scene's problem (its c is c_ref of a parametric model).
    probes, ports : sequence of float
        Positions x/L.
    parametric : bool
        A(c, d) affine for uniform c and d (:mod:`sphrom.rom.parametric`): the planes in pieces, the complement
        planes stored.
    scale_v : float
        The training run's largest |v_probe| [m s^-1] (error_tolerance's default).
    force : callable, optional
        Unused (kept for callers of the former criterion).
    T : float, optional
        The scene's horizon [s] (default the scene's T): the reference runs' and the table's span.
    target : float
        The criterion (:func:`choose_planes`).
    order : int, optional
        Force the number of planes (tests); default the criterion's.
    max_planes : int
        The largest shadow, in planes.
    port_inputs : bool
        The ports' forces are inputs of the shadow (False: a model whose port channel is exact on its own,
        :mod:`sphrom.rom.port_channel`: f alone; the port rows stay).
    count : int, optional
        Planes to compute above DENSE_LIMIT particles (default :data:`SPARSE_PLANES`).
    tail_response : bool
        Compute the uncomputed planes' free response from x0 where affordable (:func:`tail_table`); False: bound it
        through norms alone (the bench's reference model at large N).
    model_runs : callable, optional
        The model's own runs, ``model_runs(h, f, scale)`` -> (v (steps, P), ρ (steps, P)) (:func:`model_errors`):
        the shadow is sized against the model's error on the reference inputs (:func:`choose_planes`); None: against
        ``target`` alone.
    truth : sphrom.rom.lti.Truth, optional
        The truth's matrix and growth rate (:func:`sphrom.rom.lti.truth_matrix` of ``problem``: a packaging builds
        it once for the shadow and the port channel); None: built here where needed (once, for the tail table and
        the planes' residual).

    Returns
    -------
    Shadow
    """
    t_start = time.perf_counter()
    n = problem.rho0.size
    T = float(problem.scene.T if T is None else T)
    d = np.asarray(problem.d, float)
    if parametric and not (problem.terms["uniform_c"] and np.all(d == d[0])):
        raise ValueError("a parametric shadow needs uniform c and d")
    planes = decompose(problem, parametric=parametric, count=count or SPARSE_PLANES)
    C, row_e, pw, prho0 = output_rows(problem, probes, ports)
    Bcols = input_columns(problem, ports if port_inputs else ())
    x0 = np.concatenate([np.sqrt(problem.rho0) * problem.v0, np.zeros(n)])
    K = coupling(problem) if not (planes.complete or parametric) else None   # (c_ref's: fixed parameters only)
    tail = tail_of(planes, C, Bcols, x0, float(d[0]), K=K) if not planes.complete else None
    more = min(MAX_COMPUTED, int(INITIAL_BUDGET / n))
    P = len(probes)
    if tail is not None and K is not None and count is None and more > planes.count and np.any(x0):
        # the initial state as a channel: its planes never computed are bounded through norms only (Tail), which a
        # smooth x0 with a kink (tenmode's v0 at the seam, coefficients ~ k^-2) leaves loose; more planes, within
        # the budget, move them into the table (their free response exact)
        scale = float(np.max(np.abs(C[:P] @ x0)))
        if float(np.max(tail.free()[:P])) > target * scale:
            planes = decompose(problem, parametric=parametric, count=more)
            tail = tail_of(planes, C, Bcols, x0, float(d[0]), K=K)
    t_planes = time.perf_counter() - t_start
    if tail is not None and K is not None and np.any(x0) and tail_response:
        # the initial state's uncomputed planes: their free response computed where the full system's propagation
        # over the span in which their norm bound matters is affordable (tail_table), else bounded by norms
        if truth is None and tail.alpha > 0:
            truth = truth_matrix(problem)
        tail.exact = tail_table(problem, C, x0, planes, tail, T, truth=truth)
    chat = np.moveaxis(planes.right(C.T), 2, 0)                 # (rows, n, 2)
    bhat = planes.left(Bcols)                                    # (n, 2, m)
    eta = planes.left(x0)                                        # (n, 2)
    L0 = planes.blocks[0] + ((float(problem.c[0]) * planes.blocks[1] + float(d[0]) * planes.blocks[2])
                             if parametric else 0.0)
    modes_all = plane_modes(L0, chat, bhat, eta)
    # planes that must be kept: a mode an input reaches with λ = 0 or without a decay bound (the rigid motion)
    gains = mode_gains(modes_all)
    must = modes_all.plane[np.any(~np.isfinite(gains), axis=(0, 2)) | ~np.isfinite(modes_all.scale)]
    if parametric:                      # the null planes (σ = 0): unbounded where d may be 0
        must = np.concatenate([must, np.flatnonzero(planes.key <= 1e-9 * max(float(planes.key[-1]), 1e-300))])
    at_least = int(must.max()) + 1 if must.size else 1
    if order is None and len(ports) and port_inputs and planes.complete and n <= PORT_ALL_PLANES:
        order = planes.count            # (module docstring: a port's force and velocity reach every plane)
    if order is not None:
        keep, values, ref = np.arange(min(int(order), planes.count)), {}, {}
    else:
        keep, values, ref = choose_planes(planes, modes_all, chat, bhat, eta, lambda: tail, T, P, len(ports),
                                          target=target, max_planes=max_planes, at_least=at_least,
                                          table=not parametric, model_runs=None if parametric else model_runs,
                                          pw=pw, prho0=prho0, contiguous=parametric)
        if (not ref["reached"] and ref["plateau"] > ALL_PLANES_ABOVE and planes.complete and not parametric
                and n <= ALL_PLANES):
            # even the largest cut's complement is a sizeable part of a channel's response (an in-band force on a
            # lightly damped bar: its decay-weighted variation ~ u'/α against a true response ~ u'/ω): the bound
            # of any model more accurate than that would be loose (effectivities of 1e3, a false alarm); every
            # plane costs O(N) per step (a dense decomposition's N), and the complement is then empty: the bound
            # |model - truth| up to round-off.  Not where the model's own error is known and the largest cut's
            # complement is within its allowance (choose_planes: the model is no more accurate than that)
            keep = np.arange(planes.count)
    chosen = int(keep.size)
    S = planes.basis(keep)
    Sl = planes.left_basis(keep)
    B = Sl.T @ Bcols
    w0 = Sl.T @ x0
    Cs = C @ S
    A = np.zeros((3, chosen, 2, 2))
    A[:] = planes.blocks[:, keep]
    # the planes' residual (round-off of the decomposition): E = A S - S Λ, per piece for a parametric shadow
    E = np.zeros((3, 2))
    e_norm = 0.0
    growth = 0.0
    if chosen:
        truth = truth if truth is not None else truth_matrix(problem)
        lti = truth.lti
        if parametric:
            c_ref = float(problem.c[0])
            K = lti.A[:n, n:]
            pieces = [lambda X: np.vstack([np.zeros_like(X[:n]), -(K.T @ X[:n]) * 1.0]),
                      lambda X: np.vstack([K @ X[n:] / c_ref, np.zeros_like(X[n:])]),
                      lambda X: np.vstack([-X[:n], np.zeros_like(X[n:])])]
            for p, piece in enumerate(pieces):
                Ep = piece(S) - S @ sla.block_diag(*A[p])
                E[p] = [np.linalg.norm(Ep[:n], 2), np.linalg.norm(Ep[n:], 2)]
        else:
            R = lti.A @ S - S @ sla.block_diag(*A[0])
            e_norm = float(np.linalg.norm(R, 2)) * 2.0 + 1e-15 * float(abs(lti.A).sum(axis=1).max()) * \
                float(np.linalg.norm(S, 2))
            growth = truth.growth                # the residual's drift is a Duhamel integral of e^{A (t - τ)}
    restp = np.setdiff1d(np.arange(planes.count), keep)
    rest_modes = _select(modes_all, np.isin(modes_all.plane, restp))
    comp, cplanes = None, None
    if parametric:
        cplanes = {"sigma": planes.key[restp].copy(), "chat": chat[:, restp].copy(),
                   "bv": bhat[restp, 0, :].copy(), "eta": eta[restp, 0].copy()}
    else:
        # past the table, the modes left out within CONT_SHARE of the bound's round-off allowance, or within the
        # free channel's allowance of the model's own error (choose_planes), where larger (continued_modes)
        floor = CONT_SHARE * ROUNDOFF * np.linalg.norm(C, axis=1) * float(np.linalg.norm(x0))
        if "free_model_room" in ref:
            floor = np.maximum(floor, np.asarray(ref["free_model_room"], float))
        comp = complement(rest_modes, L0[restp], chat[:, restp], bhat[restp], tail, T,
                          max_nodes=int(ref.get("table_nodes", MAX_NODES)), floor=floor)
    row_norm = np.linalg.norm(C, axis=1)
    scale_v = float(scale_v) if scale_v is not None else float(np.max(np.abs(C[:P] @ x0)))
    shadow = Shadow(A=A, B=B, C=Cs, w0=w0, comp=comp, row_norm=row_norm, row_e=row_e,
                    x0_norm=float(np.linalg.norm(x0)), e_norm=e_norm,
                    b_norm=float(np.linalg.norm(B, 2)) if B.size else 0.0, pw=pw, prho0=prho0,
                    n_ports=len(ports), parametric=bool(parametric),
                    c_ref=float(problem.c[0]) if parametric else float("nan"), E=E, cplanes=cplanes,
                    growth=growth)
    shadow.info.update({"planes": int(chosen), "kept": keep.tolist(), "order": shadow.order, "target": float(target),
                        "scale_v": scale_v,
                        "criterion": {int(k): float(v) for k, v in values.items()}, **ref,
                        "computed_planes": planes.count, "complete": planes.complete,
                        "method": planes.info.get("method"), "invariant": True,
                        "tail_table": None if tail is None or tail.exact is None else
                        {"nodes": int(tail.exact.values.shape[1]), "h": tail.exact.h, "t_end": tail.exact.t_end},
                        "timings": {"planes": t_planes, "shadow": time.perf_counter() - t_start,
                                    "tail_table": 0.0 if tail is None or tail.exact is None else tail.exact.seconds}})
    return shadow


def _select(modes: Modes, sel):
    return Modes(plane=modes.plane[sel], alpha=modes.alpha[sel], mu=modes.mu[sel], absl=modes.absl[sel],
                 gamma=modes.gamma[:, sel], beta=modes.beta[sel], P=modes.P[:, sel], scale=modes.scale[sel],
                 eta=modes.eta[sel], exact=modes.exact[sel])


def fmu_shadow_applies(problem, parametric=False):
    """Whether the C core can certify an FMU of ``problem`` (:func:`fmu_shadow` builds its shadow): at most
    :data:`FMU_MAX_PARTICLES` particles, a damping that varies on at most :data:`sphrom.rom.planes.EIGEN_LIMIT`
    particles, and for a ``parametric`` model uniform c and d."""
    d = np.asarray(problem.d, float)
    if d.size > FMU_MAX_PARTICLES:
        return False
    uniform = bool(np.all(d == d[0]))
    if parametric and not (problem.terms["uniform_c"] and uniform):
        return False
    return uniform or d.size <= EIGEN_LIMIT


def fmu_shadow(problem, probes, ports=(), *, parametric=False, scale_v=None, force=None, T=None, port_inputs=True,
               model_runs=None, truth=None):
    """The shadow of an FMU's outputs, or None where the C core cannot certify it (:func:`fmu_shadow_applies`):
    more than :data:`FMU_MAX_PARTICLES` particles, a damping that varies on more than
    :data:`sphrom.rom.planes.EIGEN_LIMIT` particles, or a parametric model whose c or d is not uniform.
    ``truth``: the truth's matrix the packaging built once (:func:`sphrom.rom.lti.truth_matrix`; None: built
    here)."""
    if not fmu_shadow_applies(problem, parametric):
        return None
    return build_shadow(problem, probes, ports, parametric=parametric, scale_v=scale_v, T=T,
                        port_inputs=port_inputs, model_runs=model_runs, truth=truth)


# ---------------------------------------------------------------------------------------------------------------
# the online computation (the C core's rom_bound.c does the same, step for step)
# ---------------------------------------------------------------------------------------------------------------

def block_maps(blocks, B, h):
    """Per plane (Φ, Γ0, Γ1) of a step h: the exponential of [[Λ h, B_p h, 0], [0, 0, I], [0, 0, 0]]
    (:func:`sphrom.rom.exact_linear.propagators`; Γ1 multiplies the input's change over the step)."""
    out = []
    m = B.shape[1]
    for p, L in enumerate(blocks):
        M = np.zeros((2 + 2 * m, 2 + 2 * m))
        M[:2, :2] = L * h
        M[:2, 2:2 + m] = B[2 * p:2 * p + 2] * h
        M[2:2 + m, 2 + m:] = np.eye(m)
        E = sla.expm(M)
        out.append((E[:2, :2], E[:2, 2:2 + m], E[:2, 2 + m:]))
    return out


def growth_rate(blocks):
    """mu: the largest eigenvalue of a block's symmetric part over the blocks, 0 at least (:func:`run_shadow`)."""
    return max([0.0] + [float(np.max(np.linalg.eigvalsh(0.5 * (L + L.T)))) for L in blocks])


def free_part(comp: Complement, tau):
    """(value, error) (rows,) of the complement's free response at time ``tau`` since the start (per unit
    initial_state_scale): the table's Hermite interpolation and its certified error, or beyond the table the
    continued modes' sum (0 without them, or without a table) and the decaying tail of the others (with the sum's
    round-off allowance)."""
    if comp.values is not None and tau <= comp.t_end:
        x = tau / comp.h
        k = min(int(math.floor(x)), comp.values.shape[1] - 2)
        s = x - k
        h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
        h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
        v = (h00 * comp.values[:, k] + h01 * comp.values[:, k + 1] +
             comp.h * (h10 * comp.slopes[:, k] + h11 * comp.slopes[:, k + 1]))
        return v, comp.errors[:, k // comp.q]
    over = max(tau - comp.t_end, 0.0)
    error = comp.tail @ floored_decay(comp.rates * over)
    if comp.cont_mu is None or comp.cont_mu.size == 0:
        return np.zeros(comp.tail.shape[0]), error
    # the continued modes (free_table): Re Σ_M Q_rM e^{μ_M (τ - t_end)}, their round-off allowance (cont_roundoff)
    value = np.real(comp.cont_Q @ np.exp(comp.cont_mu * over))
    return value, error + cont_roundoff(comp, tau)


def step_weights(rates, h):
    """(e^{-α h}, (1 - e^{-α h}) / (α h)) per group: a jump's weight at the step's end, a slope's over it."""
    rates = np.asarray(rates, float)
    decay = np.exp(-rates * h)
    x = rates * h
    slope = np.where(x > 1e-8, -np.expm1(-x) / np.where(x > 1e-8, x, 1.0), 1.0 - 0.5 * x)
    return decay, slope


def run_shadow(sh: Shadow, h, u, rate, *, scale=1.0, c=None, d=None):
    """The shadow's outputs and certified row errors at the communication points.

    Parameters
    ----------
    sh : Shadow
    h : ndarray (M,)
        Communication step lengths [s] (from the start time).
    u, rate : ndarray (M, m)
        The inputs over each step (f, F_j/area) and their rates (0: held).
    scale : float
        initial_state_scale.
    c, d : float
        A parametric model's parameters.

    Returns
    -------
    (y (M+1, n_rows), cert (M+1, n_rows)): the shadow's rows (with the quasi-static feedthrough) and the bound of
    |row·x - y|.
    """
    h = np.asarray(h, float)
    u = np.atleast_2d(np.asarray(u, float)).reshape(h.size, sh.n_inputs)
    rate = np.atleast_2d(np.asarray(rate, float)).reshape(h.size, sh.n_inputs)
    blocks = sh.blocks(c, d)
    mu = growth_rate(blocks)
    cn = sh.dual_norms(c)
    enorm = sh.residual_norm(c, d)
    comp = sh.at(c, d)
    m = sh.n_inputs
    G = comp.rates.size
    w = float(scale) * sh.w0.copy()
    V = np.zeros((m, G))
    uprev = np.zeros(m)
    w_int = 0.0
    cache = {}
    Y, CERT = [], []
    tau = 0.0

    def cert(tau, n):
        init = abs(scale) * free_part(comp, tau)[1]
        static = comp.static @ np.abs(uprev)
        trans = np.einsum("rjg,jg->r", np.where(np.isfinite(comp.gain), comp.gain, 0.0), V)
        if np.any(~np.isfinite(comp.gain) & (V[None] > 0)):
            trans = np.where(np.any(~np.isfinite(comp.gain) & (V[None] > 0), axis=(1, 2)), np.inf, trans)
        allow = cn * (ROUNDOFF + ROUNDOFF_STEP * n) * (np.linalg.norm(w) + abs(scale) * sh.x0_norm)
        # the residual's drift ∫ e^{A (t - τ)} (A V_s - V_s Λ_s) w dτ: ‖e^{A s}‖ <= e^{ω s} (lti.skew_growth)
        drift = cn * enorm * w_int * growth_factor(sh.growth, tau)
        return init + static + trans + drift + allow

    Y.append(sh.C @ w + comp.D @ uprev + scale * free_part(comp, 0.0)[0])
    CERT.append(cert(0.0, 0))
    for k in range(h.size):
        hk = float(h[k])
        if hk not in cache:
            cache[hk] = (block_maps(blocks, sh.B, hk), step_weights(comp.rates, hk))
        maps, (decay, slope) = cache[hk]
        u0, r = u[k], rate[k]
        du = r * hk
        V = decay[None, :] * (V + np.abs(u0 - uprev)[:, None]) + slope[None, :] * np.abs(du)[:, None]
        V = np.where((V > 0) & (V < DECAY_FLOOR), DECAY_FLOOR, V)        # (kept normal once positive: the FMU's)
        w_int += hk * math.exp(mu * hk) * (np.linalg.norm(w) + hk * sh.b_norm * max(np.linalg.norm(u0),
                                                                                    np.linalg.norm(u0 + du)))
        new = np.empty_like(w)
        for p, (phi, g0, g1) in enumerate(maps):
            new[2 * p:2 * p + 2] = phi @ w[2 * p:2 * p + 2] + g0 @ u0 + g1 @ du
        w = new
        uprev = u0 + du
        tau += hk
        Y.append(sh.C @ w + comp.D @ uprev + scale * free_part(comp, tau)[0])
        CERT.append(cert(tau, k + 1))
    return np.array(Y), np.array(CERT)


def output_bounds(sh: Shadow, y, cert, v_model, rho_model, port_model=None):
    """The bounds of the model's outputs (module docstring) from the shadow's rows ``y`` and their ``cert`` (M, n_rows)
    and the model's v_probe (M, P), rho_probe (M, P), v_port (M, n_ports): (v_bound, rho_bound, port_bound)."""
    P = sh.n_probes
    v_bound = np.abs(np.asarray(v_model) - y[:, :P]) + cert[:, :P]
    e = y[:, P:3 * P].reshape(-1, P, 2)
    beta = cert[:, P:3 * P].reshape(-1, P, 2)
    J = 1.0 + e
    low = J - beta
    rho_s = probe_density(e, sh.pw, sh.prho0)
    with np.errstate(divide="ignore", invalid="ignore"):
        part = np.sum(sh.pw * sh.prho0 * beta / (J * low), axis=2)
    part = np.where(np.all(low > 0, axis=2), part, np.inf)
    rho_bound = np.abs(np.asarray(rho_model) - rho_s) + part + 1e-15 * np.sum(sh.pw * sh.prho0, axis=1)
    port_bound = None
    if sh.n_ports:
        port_bound = np.abs(np.asarray(port_model) - y[:, 3 * P:]) + cert[:, 3 * P:]
    return v_bound, rho_bound, port_bound


# ---------------------------------------------------------------------------------------------------------------
# the FMU's sections (resources/model.bin; fmu_src/rom_bound.c reads them)
# ---------------------------------------------------------------------------------------------------------------

def sections(sh: Shadow):
    """{tag: 2-D float64 array} of the shadow for resources/model.bin (fmu_src/rom_bound.c, section SH*):

    SHSCAL (1, 14)   k_s, planes, inputs m, rows, the table's nodes n, groups G, its node spacing h [s], its error
                     blocks' length q (intervals), ‖x0‖, ‖E‖ [s^-1], ‖B_s‖, error_tolerance's default [m s^-1],
                     complement planes n_c (a parametric shadow; else 0), the residual drift's growth rate ω
                     [s^-1] (:attr:`Shadow.growth`: its term times e^{ω t}; 0 in a parametric shadow)
    SHLAM (planes, 4)  each plane's Λ_i row-major [s^-1] (parametric: its constant piece)
    SHB (k_s, m), SHC (rows, k_s), SHW0 (1, k_s)
    SHROW (rows, 1 + 2m + m G + G)  per row: ‖c_r‖, the feedthrough D_r (m), the uncomputed planes' quasi-static
                     gains (m, times |u_j|), the transient gains H_rjg (m x G, j-major; -1: infinite), the tail
                     beyond the table (G: |g_r| <= Σ_g tail_g e^{-α_g (t - (n - 1) h)})
    SHRATE (1, G)    the groups' decay rates [s^-1]
    SHTAB (2 rows, n)  the complement's free response g_r at the nodes t_k = k h, then its slopes [per s] (per unit
                     initial_state_scale; cubic Hermite between nodes)
    SHTERR (rows, ceil((n - 1) / q))  the interpolation's certified error over the intervals of each block
    SHCONT (1 + rows, 2 M_c)  with a table, the modes continued past its end (:func:`continued_modes`; absent
                     where none is): row 0 their exponents μ_M as (Re, Im) pairs [s^-1] (Re <= 0), then per row
                     the amplitudes at the table's end P_rM e^{μ_M t_end} as (Re, Im) pairs (per unit
                     initial_state_scale); past the table g_r(t) = Re Σ_M Q_rM e^{μ_M (t - t_end)} + what SHROW's
                     tail bounds
    SHPROBE (P, 4)   per probe: the weights and ρ0 of its two particles [kg m^-3]

    Without an initial state outside the shadow: n = 0, no SHTAB, SHTERR.  A parametric shadow (Λ_i(c, d) = SHLAM_i
    + c SHPIECE_i[0:4] + d SHPIECE_i[4:8]) has n = 0, SHROW's terms after ‖c_r‖ zero and G = 2 (the C core computes
    them at (c, d) from the complement planes), and adds

    SHPIECE (planes, 8)  each plane's piece per unit c [kg^-1 m s], then per unit d [1], row-major
    SHPARAM (1, 7)       c_ref [kg m^-1 s^-2], then ‖E_p‖ of the pieces (const, c, d) row-major, v rows and e rows
    SHCPL (n_c, 2 + 2 rows + m)  per complement plane: σ_i [s^-1], η_i (its initial state's v coefficient), ĉ_ri
                     (rows x 2, at c_ref), the inputs' v coefficients b_ij (m)
    """
    m = sh.n_inputs
    rows = sh.n_rows
    comp = sh.comp
    tol = TOLERANCE_FRACTION * float(sh.info.get("scale_v", 0.0))
    n_c, nodes, h, q = 0, 0, 0.0, 1
    if sh.parametric:
        G = 2
        rates = np.zeros(2)
        row = np.zeros((rows, 1 + 2 * m + m * G + G))
        n_c = int(sh.cplanes["sigma"].size)
    else:
        G = comp.rates.size
        rates = comp.rates
        row = np.column_stack([np.zeros((rows, 1)), comp.D, comp.static, comp.gain.reshape(rows, m * G), comp.tail])
        row = np.where(np.isfinite(row), row, -1.0)          # inf gains: -1 (the C core: infinite)
        if comp.values is not None:
            nodes, h, q = comp.values.shape[1], comp.h, comp.q
    row[:, 0] = sh.row_norm
    scal = [sh.order, sh.planes, m, rows, nodes, G, h, q, sh.x0_norm,
            0.0 if sh.parametric else sh.residual_norm(), sh.b_norm, tol, n_c, sh.growth]
    out = {"SHSCAL": np.array([scal], float),
           "SHLAM": np.asarray(sh.A[0], float).reshape(-1, 4),
           "SHB": np.asarray(sh.B, float).reshape(sh.order, m),
           "SHC": np.asarray(sh.C, float).reshape(rows, sh.order),
           "SHW0": np.asarray(sh.w0, float)[None, :],
           "SHROW": row,
           "SHRATE": np.asarray(rates, float)[None, :],
           "SHPROBE": np.column_stack([sh.pw, sh.prho0])}
    if nodes:
        out["SHTAB"] = np.vstack([comp.values, comp.slopes])
        out["SHTERR"] = np.asarray(comp.errors, float)
        if comp.cont_mu is not None and comp.cont_mu.size:
            mu = np.column_stack([comp.cont_mu.real, comp.cont_mu.imag]).ravel()
            Q = np.stack([comp.cont_Q.real, comp.cont_Q.imag], axis=2).reshape(rows, -1)
            out["SHCONT"] = np.vstack([mu[None, :], Q])
    if sh.parametric:
        out["SHPIECE"] = np.column_stack([np.asarray(sh.A[1], float).reshape(-1, 4),
                                          np.asarray(sh.A[2], float).reshape(-1, 4)])
        out["SHPARAM"] = np.concatenate([[sh.c_ref], np.asarray(sh.E, float).ravel()])[None, :]
        cp = sh.cplanes
        if n_c:
            out["SHCPL"] = np.column_stack([cp["sigma"], cp["eta"], cp["chat"].transpose(1, 0, 2).reshape(n_c, -1),
                                            cp["bv"]])
    return out

"""Reduced operators of the density-linearised model (eqs. 2.17-2.24).

With v ≈ U^v a^v, ρ ≈ U^ρ a^ρ (eq. 2.18), the linearisation
1 - ρ_j(0)/ρ_j ≈ ρ_j/ρ_j(0) - 1 (eq. 2.17) turns eq. 2.11 into

    ȧ^v = -K a^ρ + b - D̂ a^v + p̂ f(t)                                 (2.19)
    ȧ^ρ = -M(a^ρ) a^v,   M = U^ρᵀ diag(ρ²/ρ0) G U^v,  ρ = U^ρ a^ρ        (2.20)

with K = U^vᵀ A U^ρ (A of eq. 2.21), b = U^vᵀ B 1 (eq. 2.22; or, with the build option ``b="rest"``,
b = K a^ρ_rest: :func:`rest_b`),
D̂ = U^vᵀ D U^v (eq. 2.24), p̂ = U^vᵀ profile, and C = diag(ρ²/ρ0) G of eq.
2.23 (the paper's C_ij has m_j/ρ_i(0), a misprint of the m_j/ρ_j(0) of eq.
2.10).  G_ij = (m_j/ρ_j(0)) ∇W_ij is the SPH gradient (eq. 2.9).

M is quadratic in a^ρ: M = Σ_{a<=b} a^ρ_a a^ρ_b T[(a,b)] with the tensor

    T[(a,b), p, q] = w_ab Σ_i U^ρ_ip U^ρ_ia U^ρ_ib (G U^v)_iq / ρ0_i,  w_ab = 1 if a = b else 2,

so the frozen-coefficient refresh costs k_ρ(k_ρ+1)/2 · k_ρ k_v operations,
independent of N, and is exact.  Pairs are ordered a = 0..k_ρ-1, b = a..k_ρ-1.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..sph.ports import port_accelerations, port_velocity_rows
from ..sph.solver import SPHProblem
from . import inputs
from .inputs import augment_channels, band, bar_modes, rigid_modes
from .model import basis_modes
from .probes import probe_rows  # noqa: F401  (its earlier home: callers import it from here)
from .protocol import Operators, two_blocks

# Above this many tensor entries the refresh falls back to the O(N k²) path.
TENSOR_MAX_ENTRIES = 20_000_000
INPUT_TOLERANCE = 1e-2      # "needed": append the input direction when the modes miss more than 1 % of it
ROUNDOFF_TOLERANCE = 1e-10  # "augment": append unless the modes hold the direction to round-off
B_FORMS = ("paper", "rest")  # b of eq. 2.19: eq. 2.22's, or K a^ρ_rest (rest an equilibrium, :func:`rest_b`)
INNERS = ("euclid", "energy")  # the projection: eq. 2.16's Φ = U, or the energy inner products (projection_weights)


def pair_index(k):
    """(a, b) for every pair a <= b in the tensor's order, shape (k(k+1)/2, 2)."""
    return np.array([(a, b) for a in range(k) for b in range(a, k)], dtype=np.int64).reshape(-1, 2)


@dataclass
class ReducedOperators(Operators):
    """Everything the density-linearised and frozen models need (the protocol of :mod:`sphrom.rom.protocol`:
    z = [a^v, a^ρ], blocks ``velocity`` and ``density``).

    Attributes
    ----------
    U_v, U_rho : ndarray (N, k_v), (N, k_rho)
        Bases (U_v with the input direction appended when augmented).
    K : ndarray (k_v, k_rho)
        U^vᵀ A U^ρ [s^-2 m^3 kg^-1 ... per unit of a^ρ], eq. 2.21.
    b : ndarray (k_v,)
        U^vᵀ B 1, eq. 2.22 (``b_form`` "paper"), or K a^ρ_rest (``b_form`` "rest", :func:`rest_b`).
    D : ndarray (k_v, k_v) or None
        U^vᵀ D U^v [s^-1], eq. 2.24; None when d ≡ 0.
    p : ndarray (k_v,) or None
        U^vᵀ profile: the input direction; None when there is no force input.
    GU_v : ndarray (N, k_v)
        G U^v, for the O(N k) and O(N k²) paths.
    inv_rho0 : ndarray (N,)
        1/ρ0 at the particles.
    T : ndarray (n_pairs, k_rho, k_v) or None
        The refresh tensor (module docstring); None above TENSOR_MAX_ENTRIES.
    a_v0, a_rho0 : ndarray
        Initial reduced coordinates U^ᵀ v0, U^ᵀ ρ0.
    input_error : float
        ||(I - U U^ᵀ) profile|| / ||profile|| of the POD velocity modes
        (before augmentation; nan without an input).
    augmented : bool
        Whether the input direction was appended to U_v.
    timings : dict
        Offline wall time [s] of the operators (``operators``, ``tensor``).
    input_mode : {"project", "augment", "moments", "never"}
        How the force entered (:func:`input_mode`), and ``input_tolerance``
        the augmentation threshold: :func:`truncate_operators` repeats the
        decision at fewer modes.
    tensor_rule : {"auto", "always", "never"}
        The ``tensor`` choice the operators were built with.
    b_form : {"paper", "rest"}
        Which b the operators hold (:data:`B_FORMS`); :func:`truncate_operators` keeps it.
    ports : tuple of float
        Port positions x/L (:mod:`sphrom.sph.ports`); empty without ports.
    Bp : ndarray (P, k_v) or None
        Input rows of the port forces at area A = 1: U^vᵀ W(x - x_j, h)/ρ0 [per N]; the run divides the forces by A.
    Cp : ndarray (P, k_v) or None
        Output rows: v_port_j = Cp[j] a^v (Σ_i W(x_i - x_j, h) v_i Δx).
    port_added, port_added_2 : int
        Columns appended to U^v and U^ρ for the ports (after the force profile's): each port's acceleration
        profile and its Krylov directions (:func:`port_directions`) outside the span of the modes before them,
        so a port force enters exactly and its local response is represented.
    port_errors : tuple of float
        Relative projection error of each port profile on the velocity modes before its column.
    input_added, input_added_2 : int
        Columns appended to U^v and U^ρ for the force profile's response at every frequency (after the profile's
        own column; :func:`sphrom.rom.inputs.augment_channels`, build option ``input_moments``).
    inner : {"euclid", "energy"}
        The projection (build option ``inner``, :func:`projection_weights`): Euclidean (eq. 2.16, Φ = U), or the energy
        inner products, whose K, b, D̂, p̂, Bp carry ρ0 and whose ``GU_v`` is diag(c/ρ0²) G U^v.
    rest_added : int
        1 when ρ0's part outside the density modes was appended to U^ρ (``inner`` "energy"), else 0.
    """

    U_v: np.ndarray
    U_rho: np.ndarray
    K: np.ndarray
    b: np.ndarray
    D: np.ndarray | None
    p: np.ndarray | None
    GU_v: np.ndarray
    inv_rho0: np.ndarray
    T: np.ndarray | None
    a_v0: np.ndarray
    a_rho0: np.ndarray
    input_error: float
    augmented: bool
    timings: dict = field(default_factory=dict)
    input_mode: str = "project"
    input_tolerance: float = ROUNDOFF_TOLERANCE
    tensor_rule: str = "auto"
    ports: tuple = ()
    Bp: np.ndarray | None = None
    Cp: np.ndarray | None = None
    port_added: int = 0
    port_errors: tuple = ()
    port_added_2: int = 0
    b_form: str = "paper"
    input_added: int = 0
    input_added_2: int = 0
    inner: str = "euclid"
    rest_added: int = 0
    channel: object = None          # the port channel (sphrom.rom.port_channel.attach): Bp None, Cp its own part

    @property
    def has_force_input(self):
        return self.p is not None

    @property
    def k_v(self):
        return self.U_v.shape[1]

    @property
    def k_rho(self):
        return self.U_rho.shape[1]

    @property
    def slices(self):
        return two_blocks("velocity", "density", self.k_v, self.k_rho)

    @property
    def z0(self):
        """The initial reduced state [a^v(0), a^ρ(0)] = [U^vᵀ v0, U^ρᵀ ρ0]."""
        return np.concatenate([self.a_v0, self.a_rho0])

    def fields(self, z):
        z = np.atleast_2d(z)
        return self.velocity(z[:, :self.k_v]), self.density(z[:, self.k_v:])

    def project(self, v, rho, problem):
        """[U^vᵀ v, U^ρᵀ ρ] per sample (eq. 2.16's projection), (M, k_v + k_rho); with ``inner`` "energy" the
        weighted projections [U^vᵀ ρ0 v, U^ρᵀ (c/ρ0²) ρ] (:func:`projection_weights`)."""
        w_v, w_rho = projection_weights(problem, self.inner)
        return np.hstack([v @ (w_v[:, None] * self.U_v), rho @ (w_rho[:, None] * self.U_rho)])

    def velocity(self, a_v):
        """v = U^v a^v at the particles, (M, N) [m s^-1] from coordinates (M, k_v)."""
        return a_v @ self.U_v.T

    def density(self, a_rho):
        """ρ = U^ρ a^ρ at the particles, (M, N) [kg m^-3] from coordinates (M, k_rho)."""
        return a_rho @ self.U_rho.T

    def strain(self, a_rho):
        """The specific-volume strain ρ0/ρ − 1 in its linearisation 1 − ρ/ρ0 (eq. 2.17) at the particles,
        (M, N) from coordinates (M, k_rho): finite for any reconstructed ρ (the blow-up check's energy)."""
        return 1.0 - self.density(a_rho) * self.inv_rho0

    def with_every_term(self):
        """The same operators with a zero damping matrix where they have none and a zero force row: the loops then
        evaluate every term, for the same numbers (what skipping the absent terms saves,
        :mod:`sphrom.bench.lib.skip`)."""
        D = self.D if self.D is not None else np.zeros((self.k_v, self.k_v))
        return dataclasses.replace(self, D=D, p=np.zeros(self.k_v))

    def basis_file_group(self):
        """The ``operators`` group of a basis file (``extra`` of :func:`sphrom.pod.io.write_basis`): K, b, D, p,
        a_v0, a_rho0, the appended input mode when the force direction was appended, and the mode counts, input
        error and offline time as attributes."""
        group = {"K": self.K, "b": self.b, "D": self.D, "p": self.p, "a_v0": self.a_v0, "a_rho0": self.a_rho0,
                 "attrs": {"k_v": self.k_v, "k_rho": self.k_rho, "augmented": int(self.augmented),
                           "input_error": self.input_error, "offline_time.operators": self.timings["operators"]}}
        if self.augmented:
            group["input_mode"] = self.U_v[:, -1]
        return group


def input_mode(input_direction, has_force, input_tolerance=None):
    """(mode, augmentation tolerance) of an ``input_direction`` (see :func:`build_operators`)."""
    mode = {"auto": "project" if has_force else "never", "always": "augment"}.get(input_direction, input_direction)
    if mode in ("needed", "moments"):
        return ("augment" if mode == "needed" else "moments"), (INPUT_TOLERANCE if input_tolerance is None
                                                                else float(input_tolerance))
    if mode not in ("project", "augment", "never"):
        raise ValueError(f"input_direction {input_direction!r}")
    return mode, ROUNDOFF_TOLERANCE if input_tolerance is None else float(input_tolerance)


def augment_with(U, direction, tol=ROUNDOFF_TOLERANCE):
    """Append the part of ``direction`` outside span(U) as a new unit column.

    Returns (U', relative projection error before augmentation, augmented?).
    Gram-Schmidt is applied twice for orthogonality to round-off.
    """
    d = np.asarray(direction, float)
    norm = np.linalg.norm(d)
    if norm == 0:
        return U, float("nan"), False
    r = d - U @ (U.T @ d)
    error = float(np.linalg.norm(r) / norm)
    if error <= tol:
        return U, error, False
    r = r - U @ (U.T @ r)
    return np.column_stack([U, r / np.linalg.norm(r)]), error, True


def projection_weights(problem, inner):
    """(w_v, w_ρ) (N,) of the projection ``inner``: ones for "euclid" (eq. 2.16, Φ = U); ρ0 and c/ρ0² for
    "energy", the weights of the energy ½ Σ ρ0 v² Δx + ½ Σ (c/ρ0²) δρ² Δx of the linearised eqs. 2.10-2.11
    (e = -δρ/ρ0 to first order)."""
    if inner == "energy":
        return problem.rho0, problem.c / problem.rho0 ** 2
    if inner == "euclid":
        return np.ones(problem.n), np.ones(problem.n)
    raise ValueError(f"inner: {inner!r} is out of range (allowed: {', '.join(INNERS)})")


def weighted_orthonormal(U, w):
    """U L⁻ᵀ with L Lᵀ = Uᵀ diag(w) U: the same span, w-orthonormal columns, the first j spanning U's first j."""
    L = np.linalg.cholesky(U.T @ (w[:, None] * U))
    return np.ascontiguousarray(np.linalg.solve(L, U.T).T)


def build_operators(problem: SPHProblem, U_v, U_rho, input_direction="auto", tensor="auto",
                    input_tolerance=None, ports=(), b="paper", input_moments=True, inner="euclid"):
    """Reduced operators for bases ``U_v`` (N, k_v) and ``U_rho`` (N, k_rho).

    Parameters
    ----------
    problem : SPHProblem
        The full SPH problem (fields, G) the bases belong to.
    input_direction : {"auto", "project", "augment", "always", "needed", "moments", "never"}
        How the force enters.  ``project`` (the paper's eq. 2.19): the input
        row p̂ = U_vᵀ profile, with whatever part of the profile the POD modes
        miss lost (its size is reported as ``input_error``).  ``augment`` (or
        ``always``): the profile's component outside span(U_v) is appended to
        the basis, so any f(t) enters exactly.  ``needed`` (the FMU, whose
        input may be anything): an input row always; the component appended
        only when the modes miss more than ``input_tolerance`` of the
        profile, else projected.  ``moments`` (the parametric frozen FMU's): the input row p̂ = U_vᵀ profile as
        ``project`` (the profile's rough residual is not appended), and the profile's response at every
        frequency (``input_moments``: the static deflection, the in-band moments) appended where the modes miss
        more than ``input_tolerance`` (default 1 %) of it.  ``never``: no input row.  ``auto``:
        ``project`` when the scene has a force, else ``never``.  Appending a
        small residual hurts: it is a rough, high-wavenumber vector that the
        Galerkin coupling excites (mild_damped_forced, k = 12: the modes miss
        0.43 % of the uniform profile; appending it raises the frozen model's
        v error against the full SPH from 3.0e-2 to 3.1e-1).
    input_tolerance : float
        The ``needed`` threshold on the relative projection error.
    tensor : {"auto", "always", "never"}
        Whether to build the refresh tensor T.
    ports : sequence of float
        Port positions x/L (:mod:`sphrom.sph.ports`): each port's acceleration profile W(x - x_j, h)/ρ0 is
        appended to U^v (its part outside the modes, always: the port force is an input of any size and shape
        in time, so its direction is kept exactly, as the exact model keeps the force profile), and the input
        rows Bp and output rows Cp are built.
    b : {"paper", "rest"}
        Eq. 2.22's b (the paper's), or b = K a^ρ_rest (:func:`rest_b`: the projected rest state is an
        equilibrium; the frozen FMU's).
    inner : {"euclid", "energy"}
        The projection.  ``euclid``: the paper's Galerkin projection (eq. 2.16, Φ = U) with Euclidean-orthonormal
        bases.  ``energy``: the bases (after every appended direction) made orthonormal in the energy inner
        products (:func:`projection_weights`: ρ0 for U^v, c/ρ0² for U^ρ) and each equation tested with them:
        K = U^vᵀ G diag(c/ρ0) U^ρ, b = U^vᵀ G c, D̂ = U^vᵀ diag(ρ0 d) U^v, p̂ = U^vᵀ ρ0 profile, Bp = U^vᵀ W, and
        M(a^ρ) = U^ρᵀ diag(ρ² c/ρ0³) G U^v (the stored ``GU_v`` is diag(c/ρ0²) G U^v, so the refresh code is the
        same).  Linearised at rest, M₀ᵀ = -K exactly for any ρ0(x), c(x): the port map is passive by structure
        (:func:`sphrom.rom.passivity.block_storage_certificate` with β = 1), which the Euclidean projection is only
        where ρ0 and c are uniform (there the two are the same model up to a scaling of the coordinates).  The
        frozen model's default for a model with ports (:func:`build_from_basis`).
    input_moments : bool
        When the force profile is appended (``augment``, ``always``, ``needed``): also its response at every
        frequency, s = 0 through the band (:func:`sphrom.rom.inputs.augment_channels`), so that a constant or
        slow force along a non-uniform profile is represented; ``project`` and ``never`` add nothing.  The
        same for each port (always).  False: the bases without them (``sphrom bench inputs`` compares).
    """
    if b not in B_FORMS:
        raise ValueError(f"b: {b!r} is out of range (allowed: {', '.join(B_FORMS)})")
    w_v, w_rho = projection_weights(problem, inner)
    t0 = time.perf_counter()
    U_v = np.ascontiguousarray(U_v, dtype=float)
    U_rho = np.ascontiguousarray(U_rho, dtype=float)
    rho0, c, d, profile = problem.rho0, problem.c, problem.d, problem.profile
    scene = problem.scene
    has_force = problem.terms["force_profile"] and bool(np.any(scene.force(np.linspace(0, scene.T, 1025)) != 0))
    mode, tol = input_mode(input_direction, has_force, input_tolerance)
    want_input = mode != "never" and bool(np.any(profile != 0))
    input_error, augmented = float("nan"), False
    if want_input:
        U_aug, input_error, added = augment_with(U_v, profile, tol=tol)
        if mode == "augment":
            U_v, augmented = U_aug, added
    wanted = want_input and input_moments and (mode == "augment" or (mode == "moments"
                                                                    and not rigid_profile(problem)))
    modes = shared_modes(problem, wanted, ports, input_moments)
    U_v, U_rho, input_added, input_added_2 = profile_moments(problem, U_v, U_rho, wanted, energy=False, tol=tol,
                                                             modes=modes)
    U_v, U_rho, port_added, port_added_rho, port_errors = augment_ports(problem, U_v, U_rho, ports,
                                                                        moments=input_moments, modes=modes)
    rest_added = 0
    if inner == "energy":
        # ρ0 itself in span(U^ρ): M₀ is then taken at ρ0 exactly, and the structure holds to round-off
        U_rho, _, rest_added = augment_with(U_rho, rho0, tol=ROUNDOFF_TOLERANCE)
        U_v, U_rho = weighted_orthonormal(U_v, w_v), weighted_orthonormal(U_rho, w_rho)
    V = w_v[:, None] * U_v                                     # the test functions: U^v, or ρ0 U^v
    G = problem.neighbours.matrix()
    inv_rho0 = 1.0 / rho0
    GU_v = w_rho[:, None] * np.asarray(G @ U_v)                # (c/ρ0²) G U^v with the energy inner products
    K = V.T @ (inv_rho0[:, None] * np.asarray(G @ ((c * inv_rho0)[:, None] * U_rho)))       # eq. 2.21
    K = np.ascontiguousarray(K)
    a_rho0 = U_rho.T @ (w_rho * rho0)
    b_vec = V.T @ (inv_rho0 * (G @ c)) if b == "paper" else rest_b(K, a_rho0)            # eq. 2.22
    D = V.T @ (d[:, None] * U_v) if problem.terms["damping"] else None                    # eq. 2.24
    p = V.T @ profile if want_input else None
    t1 = time.perf_counter()
    T = refresh_tensor(U_rho, GU_v, inv_rho0) if wants_tensor(tensor, U_v.shape[1], U_rho.shape[1]) else None
    t2 = time.perf_counter()
    return ReducedOperators(U_v=U_v, U_rho=U_rho, K=K, b=b_vec,
                            D=None if D is None else np.ascontiguousarray(D), p=p,
                            GU_v=np.ascontiguousarray(GU_v), inv_rho0=inv_rho0, T=T,
                            a_v0=V.T @ problem.v0, a_rho0=a_rho0, input_error=input_error,
                            augmented=augmented, timings={"operators": t1 - t0, "tensor": t2 - t1},
                            input_mode=mode, input_tolerance=tol, tensor_rule=tensor, b_form=b,
                            input_added=input_added, input_added_2=input_added_2, inner=inner,
                            rest_added=int(rest_added),
                            **port_rows(problem, U_v, ports, port_added, port_errors, port_added_rho, V))


# Krylov levels of each port's directions appended to the bases: the POD modes (trained on the scene's own
# force) miss the localised response to a point force; level l adds the velocity direction (ρ0⁻¹ G c G)^l b and
# the specific-volume direction G (ρ0⁻¹ G c G)^(l-1) b of the port's profile b (the short-time response).
# damped_forced, two ports, exact model, k = 12, port velocity error against the full SPH over 2 s:
# 1.56 (level 0: the profile alone), 0.34, 0.17, 0.093, 0.041, 0.023, 0.013 (levels 1-6); with the FMU
# (python -m sphrom.bench.port_coupling, 1 ms steps) 0.0119 at 6 levels, 0.0040 at 8, 0.0028 at 10, against
# 0.0021 for the same FMU's free response.  Each level adds one velocity and one specific-volume column per
# port, and the frozen model's refresh tensor grows as k_ρ³ k_v / 2: 8 levels.
PORT_KRYLOV_LEVELS = 8


def port_directions(problem, ports, levels=PORT_KRYLOV_LEVELS):
    """Per port: (velocity directions [b, (ρ0⁻¹ G c G) b, ...], specific-volume directions [G b, ...]).

    b = W(x - x_j, h)/ρ0 (:func:`sphrom.sph.ports.port_accelerations`, area 1): the first velocity direction is
    the port's profile itself; each further level follows ė = G v, ρ0 v̇ = G (c e) (eqs. 2.10-2.11 in the
    specific volume, eq. A.9).
    """
    G = problem.neighbours.matrix()
    out = []
    for b in port_accelerations(problem, ports):
        vs, es = [b], []
        for _ in range(levels):
            es.append(np.asarray(G @ vs[-1]))
            vs.append(np.asarray(G @ (problem.c * es[-1])) / problem.rho0)
        out.append((vs, es))
    return out


def augment_ports(problem, U_v, U_2, ports, *, energy=False, levels=PORT_KRYLOV_LEVELS, moments=True, tol=None,
                  modes=None):
    """(U_v, U_2, velocity columns added, second columns added, projection errors) with the port directions.

    Each direction of :func:`port_directions` is appended (its part outside the span, unless below round-off):
    velocity directions to U_v, specific-volume directions to U_2 (``energy``: the exact model's ρ0- and
    c-weighted inner products and U_2 = U_e; else Euclidean and U_2 = U_ρ, which gets ρ0 G v: δρ = -ρ0 δe).
    The errors are each port profile's relative projection error on the velocity modes before its column.
    ``moments``: then each port's response at every frequency (:func:`sphrom.rom.inputs.augment_channels`;
    False: the short-time directions only); ``modes`` the bar's modes if already solved for.
    """
    if not len(ports):
        return U_v, U_2, 0, 0, ()

    def add(U, d, w):
        if not energy:
            return augment_with(U, d, tol=ROUNDOFF_TOLERANCE)
        s = np.sqrt(w)               # W-orthogonal in the weights w = Euclidean in sqrt(w) x
        U, error, added = augment_with(s[:, None] * U, s * d, tol=ROUNDOFF_TOLERANCE)
        return U / s[:, None], error, added

    n_v, n_2, errors = U_v.shape[1], U_2.shape[1], []
    w_top = band(problem, U_v)[1]                    # the band of the modes, before the port columns
    for vs, es in port_directions(problem, ports, levels):
        U_v, error, _ = add(U_v, vs[0], problem.rho0)
        errors.append(error)
        for v, e in zip(vs[1:], es):
            U_2, _, _ = add(U_2, e if energy else problem.rho0 * e, problem.c)
            U_v, _, _ = add(U_v, v, problem.rho0)
    # the response at every frequency, s = 0 (static, rigid) through the band (sphrom.rom.inputs)
    if moments:
        U_v, U_2, _, _ = augment_channels(problem, U_v, U_2, port_accelerations(problem, ports), energy=energy,
                                          w_top=w_top, tol=tol, modes=modes)
    return (np.ascontiguousarray(U_v), np.ascontiguousarray(U_2), U_v.shape[1] - n_v, U_2.shape[1] - n_2,
            tuple(errors))


def rigid_profile(problem):
    """Whether the force profile is a rigid motion (in ker G: the constant, or the alternating function of an
    even N): its response at every frequency is then that motion alone, which the POD modes of its own runs hold
    to their projection error.  ``input_direction="moments"`` appends nothing for it: the rigid direction's
    residual outside a parametric basis is rough (tenmode, c in [0.05, 0.2], d in [0, 5], k = 12: 1.2 % of the
    constant), and appending it raised the held-out probe-velocity error from at most 1.12x to 1.66x that of a
    model trained at the point (measured once by ``python -m sphrom.bench.parametric --input-direction
    moments`` before this rule; with the rule that command gives the "project" model's figures again)."""
    profile = np.asarray(problem.profile, float)
    norm = float(np.linalg.norm(profile))
    if norm == 0:
        return True
    R = rigid_modes(problem.neighbours.matrix())
    if not R.shape[1]:
        return False
    Q = np.linalg.qr(R)[0]
    return bool(np.linalg.norm(profile - Q @ (Q.T @ profile)) <= 1e-12 * norm)


def profile_moments(problem, U_v, U_2, wanted, *, energy, tol, modes=None):
    """(U_v, U_2, columns added to each) with the force profile's directions at every frequency
    (:func:`sphrom.rom.inputs.augment_channels`), or the bases unchanged unless ``wanted``.  ``tol``: the input
    mode's augmentation threshold; a direction is appended when the bases miss more than it or
    :data:`sphrom.rom.inputs.INPUT_TOL`, whichever is larger (``needed``, the frozen FMU's: 1 %, as for the
    profile itself: a small rough residual appended hurts the frozen model).  ``modes``: the bar's modes if
    already solved for."""
    if not wanted:
        return U_v, U_2, 0, 0
    return inputs.augment_channels(problem, U_v, U_2, [problem.profile], energy=energy,
                                   tol=max(inputs.INPUT_TOL, tol), modes=modes)


def shared_modes(problem, profile_wanted, ports, moments):
    """:func:`sphrom.rom.inputs.bar_modes` when both the profile's and the ports' channels will take modes (one
    eigensolve for both; a dense one at N = 2000 takes seconds), else None (each computes its own if it needs
    them)."""
    if not (profile_wanted and len(ports) and moments):
        return None
    return bar_modes(problem)


def port_rows(problem, U_v, ports, port_added, port_errors, port_added_2=0, V=None):
    """The port fields of :class:`ReducedOperators`: Bp = (Vᵀ W/ρ0)ᵀ (area 1; V the test functions, default U^v)
    and Cp = (W Δx) U^v."""
    if not len(ports):
        return {}
    V = U_v if V is None else V
    return {"ports": tuple(float(x) for x in ports), "Bp": np.ascontiguousarray(port_accelerations(problem, ports) @ V),
            "Cp": np.ascontiguousarray(port_velocity_rows(problem, ports) @ U_v), "port_added": port_added,
            "port_added_2": port_added_2, "port_errors": port_errors}


def rest_b(K, a_rho_rest):
    """b = K a^ρ_rest (k_v,): the b of eq. 2.19 that makes the projected rest state (a^v = 0, a^ρ = U^ρᵀ ρ0) an
    equilibrium (the build option ``b="rest"``, the frozen FMU's model).

    Eq. 2.22's b = U^vᵀ ρ0⁻¹ G c and K a^ρ (eq. 2.21) cancel at rest only as far as ρ0 lies in the span of
    the density modes: K a^ρ - b = U^vᵀ ρ0⁻¹ G c (ρ0⁻¹ U^ρ a^ρ - 1), which at a^ρ = U^ρᵀ ρ0 leaves the
    constant force U^vᵀ ρ0⁻¹ G c ρ0⁻¹ (P ρ0 - ρ0) of the projection error of ρ0 (P = U^ρ U^ρᵀ).  A reduced
    model started at rest then drifts, and so does every run of it by that force.  Taking the linearisation
    of eq. 2.17 about the projected rest density instead, ρ/ρ0 - 1 ≈ ρ0⁻¹ U^ρ (a^ρ - a^ρ_rest), keeps K and
    replaces b by K a^ρ_rest (the exact model's deviation form z = 0 at rest does the same).  At rest the
    velocity rate b - K a^ρ_rest is then zero up to the round-off of the k_ρ products.

    ``a_rho_rest`` is U^ρᵀ ρ0, the operators' a^ρ(0) (every scene starts at ρ = ρ0).  For the model affine in
    c (:mod:`sphrom.rom.parametric`) the unit operators' b_c = K_c a^ρ_rest keeps b = c b_c = K a^ρ_rest at
    every c.
    """
    return np.ascontiguousarray(K @ a_rho_rest)          # eq. 2.22 about the projected rest density


def wants_tensor(tensor, k_v, k_rho):
    """Whether the rule ``tensor`` ({"auto", "always", "never"}) builds the refresh tensor at k_v, k_rho."""
    n_pairs = k_rho * (k_rho + 1) // 2
    return {"auto": n_pairs * k_rho * k_v <= TENSOR_MAX_ENTRIES, "always": True, "never": False}[tensor]


def build_from_basis(problem: SPHProblem, basis, k_v, k_rho, *, input_direction="auto", input_tolerance=None,
                     tensor="auto", ports=(), b="paper", input_moments=True, inner="auto"):
    """:func:`build_operators` on the first k_v, k_rho POD modes of ``basis`` (``Basis.U_v``, ``Basis.U_rho``).

    The builder of the frozen model (:mod:`sphrom.rom.model`; its registry default ``b="rest"``).  ``inner``
    "auto": the energy inner products with ports (a passive port map on every scene), else eq. 2.16's Euclidean
    projection (the paper's model).
    """
    U_v, U_rho = basis_modes(basis, "density", k_v, k_rho)
    if inner == "auto":
        inner = "energy" if len(ports) else "euclid"
    return build_operators(problem, U_v, U_rho, input_direction=input_direction, tensor=tensor,
                           input_tolerance=input_tolerance, ports=ports, b=b, input_moments=input_moments,
                           inner=inner)


def build_paper(problem: SPHProblem, basis, k_v, k_rho, *, input_direction="auto", input_tolerance=None,
                tensor="auto", ports=()):
    """:func:`build_from_basis` with eq. 2.22's b: the builder of the paper's original and density-linearised
    models (:mod:`sphrom.rom.model`)."""
    return build_from_basis(problem, basis, k_v, k_rho, input_direction=input_direction,
                            input_tolerance=input_tolerance, tensor=tensor, ports=ports, b="paper", inner="euclid")


def truncate_operators(problem: SPHProblem, ops: ReducedOperators, k_v, k_rho):
    """The operators of the first ``k_v`` POD velocity and ``k_rho`` density modes of ``ops``, without a rebuild.

    K, b, D̂, p̂, G U^v, the initial coordinates and the refresh tensor T (its
    pairs (a, b), a <= b < k_rho, re-indexed) are slices of the larger ones:
    each entry is the same sum over the particles, so they equal
    :func:`build_operators` at the smaller counts to round-off (the dense
    products may group the sum differently).  What a slice cannot give is
    rebuilt: the input direction's projection error at k_v, and, when the
    force profile is appended to U^v (``input_mode`` augment), the appended
    column - the profile's part outside the first k_v modes differs from its
    part outside all of them - with its row of K, b, D̂, p̂, its column of G U^v
    and of T, at O(N k) (O(N k³) for T).  A tensor the larger operators did
    not have (k above TENSOR_MAX_ENTRIES) is built when the rule now asks for one.

    Parameters
    ----------
    problem : SPHProblem
        The problem ``ops`` were built on.
    ops : ReducedOperators
    k_v : int
        POD velocity modes to keep (at most ``ops.k_v``, less the appended input direction).
    k_rho : int
        Density modes to keep (at most ``ops.k_rho``).
    """
    t0 = time.perf_counter()
    kv_pod = ops.k_v - int(ops.augmented) - ops.port_added - ops.input_added
    kr_pod = ops.k_rho - ops.port_added_2 - ops.input_added_2 - ops.rest_added
    if not (1 <= k_v <= kv_pod and 1 <= k_rho <= kr_pod):
        raise ValueError(f"k_v, k_rho = {k_v}, {k_rho} out of range (allowed: 1 to {kv_pod}, 1 to {kr_pod})")
    if ops.ports or ops.input_added or ops.input_added_2 or ops.inner != "euclid":
        # input columns depend on every mode before them; weighted bases are re-orthonormalised as a whole
        # (from Euclidean-orthonormal columns of the same nested spans, which the appending expects)
        U_v, U_rho = ops.U_v[:, :k_v], ops.U_rho[:, :k_rho]
        if ops.inner != "euclid":
            U_v, U_rho = np.linalg.qr(U_v)[0], np.linalg.qr(U_rho)[0]
        return build_operators(problem, U_v, U_rho,
                               input_direction=ops.input_mode if ops.p is not None else "never",
                               tensor=ops.tensor_rule, input_tolerance=ops.input_tolerance, ports=ops.ports,
                               b=ops.b_form, inner=ops.inner)
    rho0, c, d, profile = problem.rho0, problem.c, problem.d, problem.profile
    inv_rho0 = ops.inv_rho0
    U_pod = ops.U_v[:, :k_v]
    U_rho = np.ascontiguousarray(ops.U_rho[:, :k_rho])
    input_error, augmented, U_v = float("nan"), False, U_pod
    if ops.p is not None:
        U_aug, input_error, added = augment_with(U_pod, profile, tol=ops.input_tolerance)
        if ops.input_mode == "augment":
            U_v, augmented = U_aug, added
    U_v = np.ascontiguousarray(U_v)
    K = ops.K[:k_v, :k_rho]
    b = ops.b[:k_v]
    D = None if ops.D is None else ops.D[:k_v, :k_v]
    p = None if ops.p is None else ops.p[:k_v]
    GU_v = ops.GU_v[:, :k_v]
    a_v0 = ops.a_v0[:k_v]
    if augmented:                                   # the appended column u and its rows, as build_operators
        u = U_v[:, -1]
        G = problem.neighbours.matrix()
        Gu = np.asarray(G @ u)
        GU_v = np.column_stack([GU_v, Gu])
        K = np.vstack([K, u @ (inv_rho0[:, None] * np.asarray(G @ ((c * inv_rho0)[:, None] * U_rho)))])  # eq. 2.21
        b = np.append(b, u @ (inv_rho0 * (G @ c)))                                                    # eq. 2.22
        if D is not None:                                                                             # eq. 2.24
            D = np.vstack([np.column_stack([D, U_pod.T @ (d * u)]), u @ (d[:, None] * U_v)])
        p = np.append(p, u @ profile)
        a_v0 = np.append(a_v0, u @ problem.v0)
    a_rho0 = np.ascontiguousarray(ops.a_rho0[:k_rho])
    K = np.ascontiguousarray(K)
    if ops.b_form == "rest":                        # K a^ρ_rest of the kept modes, not a slice of the larger one
        b = rest_b(K, a_rho0)
    t1 = time.perf_counter()
    T = None
    if ops.T is not None and wants_tensor(ops.tensor_rule, U_v.shape[1], k_rho):
        index = {tuple(pair): i for i, pair in enumerate(pair_index(ops.k_rho))}
        rows = [index[tuple(pair)] for pair in pair_index(k_rho)]
        T = ops.T[rows][:, :k_rho, :k_v]
        if augmented:
            T = np.concatenate([T, refresh_tensor(U_rho, GU_v[:, -1:], inv_rho0)], axis=2)
    elif wants_tensor(ops.tensor_rule, U_v.shape[1], k_rho):
        T = refresh_tensor(U_rho, np.ascontiguousarray(GU_v), inv_rho0)
    t2 = time.perf_counter()
    return ReducedOperators(U_v=U_v, U_rho=U_rho, K=K, b=np.ascontiguousarray(b),
                            D=None if D is None else np.ascontiguousarray(D),
                            p=None if p is None else np.ascontiguousarray(p), GU_v=np.ascontiguousarray(GU_v),
                            inv_rho0=inv_rho0, T=None if T is None else np.ascontiguousarray(T),
                            a_v0=np.ascontiguousarray(a_v0), a_rho0=a_rho0,
                            input_error=input_error, augmented=augmented,
                            timings={"operators": t1 - t0, "tensor": t2 - t1},
                            input_mode=ops.input_mode, input_tolerance=ops.input_tolerance,
                            tensor_rule=ops.tensor_rule, b_form=ops.b_form)


def triple_index(k):
    """(i, j, l) for every triple i <= j <= l (lexicographic), shape (k(k+1)(k+2)/6, 3), and the (k, k, k) table
    of each index triple's position among them (sorted first)."""
    triples = np.array([(i, j, l) for i in range(k) for j in range(i, k) for l in range(j, k)],
                       dtype=np.int64).reshape(-1, 3)
    table = np.empty((k, k, k), dtype=np.int64)
    for t, (i, j, l) in enumerate(triples):
        for a, b, c in {(i, j, l), (i, l, j), (j, i, l), (j, l, i), (l, i, j), (l, j, i)}:
            table[a, b, c] = t
    return triples, table


def refresh_tensor(U_rho, GU_v, inv_rho0):
    """T[(a,b), p, q] of the module docstring, shape (k_rho(k_rho+1)/2, k_rho, k_v).

    T[(a,b), p] = w_ab W[{a, b, p}]: W (k_rho(k_rho+1)(k_rho+2)/6, k_v), one row per sorted index triple, is
    computed once, so that T is symmetric in (a, b, p) bit for bit (w_ab = 2 scales exactly) and the C core
    can keep W alone (fmu_src/rom_frozen.c, the symmetric refresh)."""
    k_r = U_rho.shape[1]
    pairs = pair_index(k_r)
    triples, table = triple_index(k_r)
    prods = U_rho[:, triples[:, 0]] * U_rho[:, triples[:, 1]] * U_rho[:, triples[:, 2]] * inv_rho0[:, None]
    W = prods.T @ GU_v                                                         # (n_triples, k_v)
    weights = np.where(pairs[:, 0] == pairs[:, 1], 1.0, 2.0)
    rows = table[pairs[:, 0][:, None], pairs[:, 1][:, None], np.arange(k_r)[None, :]]   # (n_pairs, k_r)
    return np.ascontiguousarray(W[rows] * weights[:, None, None])             # (n_pairs, k_r, k_v)


def density_matrix(ops: ReducedOperators, a_rho):
    """M(a^ρ) = U^ρᵀ diag(ρ²/ρ0) G U^v by the straightforward O(N k²) path."""
    rho = ops.U_rho @ a_rho
    return ops.U_rho.T @ ((rho * rho * ops.inv_rho0)[:, None] * ops.GU_v)

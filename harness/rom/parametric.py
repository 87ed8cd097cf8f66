"""A parametric reduced model: one POD basis over a range of the stiffness c and the damping d.

For a scene with uniform c and d the reduced operators are affine in them
(eqs. 2.21-2.24): the frozen model's

    K = c K_c,   b = c b_c,   D̂ = d D_d                          (eqs. 2.21, 2.22, 2.24)

with K_c, b_c, D_d the operators of c = 1, d = 1 on the same basis; the
refresh tensor T (eq. 2.23, from U^ρ, G U^v and 1/ρ0 only) and the input row p̂
do not depend on c or d.  The exact linear model (:mod:`.exact_linear`) in the
coordinates v = U_v a, e = U_e b with U_e orthonormal in the weight c_ref (the
scene's c) has

    ȧ = -d D_d a + c P_1 b + p̂ f,   ḃ = -c_ref P_1ᵀ a,   P_1 = U_vᵀ G U_e,

so A = A_0 + c A_c + d A_d with A_0 = [[0, 0], [-c_ref P_1ᵀ, 0]],
A_c = [[0, P_1], [0, 0]], A_d = [[-D_d, 0], [0, 0]].  (The Galerkin projection
of ė = G v on span(U_e) does not depend on the inner product when c is
uniform; U_eᵀ U_e = I/c_ref gives the factor c_ref.)  It equals the ordinary
exact model built at (c, d) on the same span, whose U_e is c-orthonormal
(U_e sqrt(c_ref/c)), up to the change of coordinates b_ordinary = sqrt(c/c_ref) b.
A(c, 0) is skew only at c = c_ref, so the parametric exact model is always
advanced by the matrix exponential (no Schur form): a form skew at every c
would need sqrt(c), which is not affine.

Online the model is assembled from (c, d) in O(k²), never touching N; the
C core does the same at ExitInitializationMode, in the same order.

Training: full SPH runs at sample points of the range (:func:`training_points`:
the corners and the centre), one POD of the combined snapshots
(:func:`training_basis`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..cache import cached_sph
from ..errors import FieldError
from ..pod.basis import Basis, pod, weighted_pod
from ..pod.pipeline import error_steps
from ..pod.snapshots import describe, snapshot_steps
from ..scene import derive_scene
from ..sph.solver import build_problem, step_count
from .exact_linear import build_linear_operators
from .operators import build_operators

PARAMETERS = ("c", "d")
UNITS = {"c": "kg m^-1 s^-2", "d": "s^-1"}        # c: Young's modulus (Pa in 1D: force per ...), d: damping rate


@dataclass(frozen=True)
class Range:
    """A trained range of one parameter.

    Attributes
    ----------
    name : {"c", "d"}
    lo, hi : float
        Bounds, c in kg m^-1 s^-2 (> 0), d in s^-1 (>= 0); lo < hi.
    """

    name: str
    lo: float
    hi: float


def parse_vary(text):
    """``"c=0.05:0.2"`` -> Range; FieldError naming the field ``vary`` on a bad text or bound."""
    name, sep, bounds = str(text).partition("=")
    name = name.strip()
    lo_text, sep2, hi_text = bounds.partition(":")
    allowed = "c=LO:HI or d=LO:HI with 0 < LO < HI for c, 0 <= LO < HI for d"
    if not sep or not sep2 or name not in PARAMETERS:
        raise FieldError("vary", f"{text!r} is not a parameter range (allowed: {allowed})")
    try:
        lo, hi = float(lo_text), float(hi_text)
    except ValueError:
        raise FieldError("vary", f"{text!r}: the bounds are not numbers (allowed: {allowed})") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi and (lo > 0 if name == "c" else lo >= 0)):
        raise FieldError("vary", f"{text!r} is out of range (allowed: {allowed})")
    return Range(name, lo, hi)


def uniform_value(problem, name):
    """The value of the field ``name`` ("c" or "d") of an SPHProblem, which must be uniform.

    Raises FieldError naming ``fields.<name>`` when the field varies in x.
    """
    values = getattr(problem, name)
    if not np.all(values == values[0]):
        raise FieldError(f"fields.{name}", f"scene '{problem.scene.name}' has a non-uniform {name}(x) "
                                           f"(from {values.min():g} to {values.max():g}); a parametric model needs a "
                                           f"uniform {name}")
    return float(values[0])


@dataclass(frozen=True)
class ParameterSpace:
    """The varied parameters of a parametric model and the scene's values.

    Attributes
    ----------
    ranges : dict of str to Range
        The varied parameters (one or both of c, d).
    scene_values : dict of str to float
        c [kg m^-1 s^-2] and d [s^-1] of the scene (the reference c_ref is the scene's c).
    """

    ranges: dict
    scene_values: dict

    def varies(self, name):
        return name in self.ranges

    def start(self, name):
        """The FMU start value: the scene's value when inside the range, else the range's midpoint."""
        value = self.scene_values[name]
        r = self.ranges.get(name)
        if r is None or r.lo <= value <= r.hi:
            return value
        return 0.5 * (r.lo + r.hi)

    def bounds(self, name):
        """(lo, hi) of a varied parameter, (value, value) of a fixed one."""
        r = self.ranges.get(name)
        return (r.lo, r.hi) if r else (self.scene_values[name],) * 2

    def check(self, c, d):
        """FieldError ("c = 0.3 is outside the trained range [0.05, 0.2]") when (c, d) leaves the space."""
        for name, value in (("c", c), ("d", d)):
            lo, hi = self.bounds(name)
            if not (math.isfinite(value) and lo <= value <= hi):
                raise FieldError(name, f"{name} = {value:g} is outside the trained range [{lo:g}, {hi:g}]")

    @property
    def c_ref(self):
        return self.scene_values["c"]


def parameter_space(problem, ranges):
    """A ParameterSpace from the scene's problem and Ranges (FieldError for a repeated or non-uniform field)."""
    by_name = {}
    for r in ranges:
        if r.name in by_name:
            raise FieldError("vary", f"{r.name} is given twice (allowed: each of c, d at most once)")
        by_name[r.name] = r
    if not by_name:
        raise FieldError("vary", "no parameter range (allowed: c=LO:HI, d=LO:HI)")
    values = {name: uniform_value(problem, name) for name in by_name}
    for name in PARAMETERS:
        if name not in values:
            values[name] = uniform_value(problem, name)
    return ParameterSpace(ranges=by_name, scene_values=values)


def training_points(space):
    """Sample points (m, 2) of (c, d): the corners of the varied box and its centre.

    The operators are exactly affine in c and d, so the samples only serve the
    basis: the corners hold the extremes of frequency (c) and decay (d), the
    centre an interior trajectory.  One varied parameter: its two ends and the
    midpoint.  A parameter not varied stays at the scene's value.
    """
    axes = []
    for name in PARAMETERS:
        lo, hi = space.bounds(name)
        axes.append([lo, hi] if space.varies(name) else [lo])
    corners = [(c, d) for c in axes[0] for d in axes[1]]
    centre = tuple(0.5 * sum(space.bounds(name)) for name in PARAMETERS)
    return np.array(corners + [centre], dtype=float)


def held_out_points(space, count=10):
    """``count`` points (c, d) of the Halton sequence (bases 2, 3) in the trained box: none is a training point."""
    def radical(i, base):
        f, r = 1.0, 0.0
        while i > 0:
            f /= base
            r += f * (i % base)
            i //= base
        return r
    out = []
    for i in range(1, count + 1):
        point = []
        for name, base in zip(PARAMETERS, (2, 3)):
            lo, hi = space.bounds(name)
            point.append(lo + radical(i, base) * (hi - lo) if space.varies(name) else lo)
        out.append(point)
    pts = np.array(out, dtype=float)
    train = training_points(space)
    keep = [p for p in pts if not np.any(np.all(np.isclose(train, p), axis=1))]
    return np.array(keep, dtype=float)


def scene_at(scene, c, d):
    """The scene with uniform c [kg m^-1 s^-2] and d [s^-1] (a derived scene, validated as a file)."""
    return derive_scene(scene, {"fields": {"c": repr(float(c)), "d": repr(float(d))}})


def training_basis(scene, points, progress=True):
    """One POD basis (:class:`sphrom.pod.basis.Basis`) of the snapshots of full SPH runs at ``points``.

    Each run (cached like every SPH run) gives its snapshots at the scene's
    snapshot steps; the columns of all runs are put side by side and one SVD
    taken per field (eq. 2.15).  The energy-weighted bases of the exact model:
    velocity weighted by ρ0 (the same in every run); each run's specific
    volume e weighted by its own c (its energy), the modes then made
    orthonormal in the scene's c (c_ref).

    Returns (basis, runs): ``runs`` the CachedRun of each point.
    """
    spec = dict(scene.snapshots)
    if spec.get("all"):
        raise FieldError("snapshots", "a parametric basis needs a snapshot count and window (not all samples)")
    n = step_count(scene.T, scene.sph.dt)
    sv, sr = snapshot_steps(spec, scene.sph.dt, n, n_particles=scene.sph.n_particles)
    cols_v, cols_r, cols_e, runs = [], [], [], []
    problem0 = build_problem(scene)
    rho0 = problem0.rho0
    for c, d in points:
        s = scene_at(scene, c, d)
        run = cached_sph(s, np.union1d(error_steps(s), np.union1d(sv, sr)), progress=progress)
        runs.append(run)
        iv = np.searchsorted(run.steps, sv)
        ir = np.searchsorted(run.steps, sr)
        cols_v.append(run.v[iv].T)
        cols_r.append(run.rho[ir].T)
        cols_e.append(math.sqrt(c) * (rho0[None, :] / run.rho[ir] - 1.0).T)
    V, R, E = (np.concatenate(cols, axis=1) for cols in (cols_v, cols_r, cols_e))
    U_v, s_v = pod(V)
    U_r, s_r = pod(R)
    U_ve, s_ve = weighted_pod(V, rho0)
    U_e, s_e = pod(E)
    c_ref = float(problem0.c[0])
    strategy = f"{describe(spec)} at {len(points)} parameter points"
    basis = Basis(U_v=U_v, U_rho=U_r, sigma_v=s_v, sigma_rho=s_r, steps_v=np.asarray(sv), steps_rho=np.asarray(sr),
                  x=problem0.x, dt=scene.sph.dt, scene_text=scene.text, strategy=strategy,
                  U_ve=U_ve, sigma_ve=s_ve, U_e=U_e / math.sqrt(c_ref), sigma_e=s_e)
    basis.attrs["parameter_points"] = np.asarray(points, float)
    return basis, runs


# ---- the frozen model (eqs. 2.19-2.24) -------------------------------------------------------------------

@dataclass
class AffineFrozen:
    """The frozen model's operators affine in (c, d).

    Attributes
    ----------
    unit : ReducedOperators
        Built at c = 1 kg m^-1 s^-2, d = 1 s^-1 on the basis: ``unit.K`` is K_c
        (per unit c), ``unit.b`` b_c, ``unit.D`` D_d (per unit d, None when
        the model has no damping term at any d of the space); T, p̂, the bases and
        initial coordinates are the model's at every (c, d).
    space : ParameterSpace
    damping : bool
        D̂ = d D_d is part of the model (d varied, or the scene's d > 0).
    """

    unit: object
    space: ParameterSpace
    damping: bool
    timings: dict = field(default_factory=dict)


def affine_frozen(scene, space, U_v, U_rho, *, input_direction="auto", input_tolerance=None, tensor="auto"):
    """K_c, b_c, D_d, T, p̂ of the bases ``U_v`` (N, k_v), ``U_rho`` (N, k_rho): :class:`AffineFrozen`.

    ``input_direction``, ``input_tolerance``, ``tensor`` as in
    :func:`sphrom.rom.operators.build_operators` (the profile does not depend on c, d).
    """
    unit_problem = build_problem(scene_at(scene, 1.0, 1.0))
    unit = build_operators(unit_problem, U_v, U_rho, input_direction=input_direction, tensor=tensor,
                           input_tolerance=input_tolerance, b="rest")         # b_c = K_c a^ρ_rest, as the FMU
    damping = space.varies("d") or space.scene_values["d"] != 0
    return AffineFrozen(unit=unit, space=space, damping=damping, timings=dict(unit.timings))


def frozen_at(model: AffineFrozen, c, d):
    """The frozen model's ReducedOperators at (c [kg m^-1 s^-2], d [s^-1]), assembled in O(k²).

    K = c K_c, b = c b_c (eqs. 2.21, 2.22; b_c = K_c a^ρ_rest, so rest is an equilibrium at every c), D̂ = d D_d (eq. 2.24): each entry one
    product, as the C core assembles them.  FieldError outside the trained range.
    """
    model.space.check(c, d)
    u = model.unit
    K = float(c) * u.K                                     # eq. 2.21
    b = float(c) * u.b                                     # eq. 2.22
    D = float(d) * u.D if model.damping else None          # eq. 2.24
    return dataclasses.replace(u, K=np.ascontiguousarray(K), b=np.ascontiguousarray(b),
                               D=None if D is None else np.ascontiguousarray(D), timings={"operators": 0.0})


# ---- the exact linear model -----------------------------------------------------------------------------

@dataclass
class AffineLinear:
    """The exact linear model's A = A_0 + c A_c + d A_d (module docstring).

    Attributes
    ----------
    unit : LinearOperators
        Built at c = 1, d = 1 on U_v and the c_ref-orthonormal U_e: B, z0, the
        bases; P_1 and D_d are its blocks.
    A0, Ac, Ad : ndarray (k, k)
    space : ParameterSpace
    """

    unit: object
    A0: np.ndarray
    Ac: np.ndarray
    Ad: np.ndarray
    space: ParameterSpace
    timings: dict = field(default_factory=dict)


def affine_linear(scene, space, U_v, U_e, *, input_direction="auto", input_tolerance=None):
    """A_0, A_c, A_d of ρ0-orthonormal ``U_v`` and c_ref-orthonormal ``U_e`` (c_ref: the scene's c): AffineLinear."""
    # built at c = c_ref (d = 1): the input directions it appends to U_e are then c_ref-orthonormal, as U_e is
    # (at c = 1 they were Euclidean-normalised beside c_ref-orthonormal columns, and the affine A below, which
    # takes U_eᵀ c_ref U_e = I, was wrong along a non-uniform profile: of order 1 where it is 1e-12 now, python -m
    # sphrom.bench.inputs --case parametric-profile-sine)
    unit_problem = build_problem(scene_at(scene, space.c_ref, 1.0))
    unit = build_linear_operators(unit_problem, U_v, U_e, input_direction=input_direction,
                                  input_tolerance=input_tolerance)
    kv, ke = unit.k_v, unit.k_e
    k = kv + ke
    P1 = unit.A[:kv, kv:] / space.c_ref                    # U_vᵀ G (1 · U_e)
    D1 = -unit.A[:kv, :kv]                                 # U_vᵀ diag(ρ0 · 1) U_v
    A0, Ac, Ad = np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, k))
    A0[kv:, :kv] = -(space.c_ref * P1.T)
    Ac[:kv, kv:] = P1
    Ad[:kv, :kv] = -D1
    return AffineLinear(unit=unit, A0=A0, Ac=Ac, Ad=Ad, space=space, timings=dict(unit.timings))


def assemble_linear(A0, Ac, Ad, c, d):
    """A = A_0 + c A_c + d A_d [s^-1], entry by entry left to right (the C core's order)."""
    return (A0 + float(c) * Ac) + float(d) * Ad


def linear_at(model: AffineLinear, c, d):
    """The exact model's LinearOperators at (c, d): A assembled in O(k²), advanced by the exponential (no Schur)."""
    model.space.check(c, d)
    A = assemble_linear(model.A0, model.Ac, model.Ad, c, d)
    return dataclasses.replace(model.unit, A=A, skew=False, schur_Q=None, schur_T=None, timings={"operators": 0.0})


def ordinary_basis_e(space, U_e, c):
    """U_e made c-orthonormal (U_e sqrt(c_ref/c)): the basis the ordinary exact model builds on at c."""
    return U_e * math.sqrt(space.c_ref / float(c))

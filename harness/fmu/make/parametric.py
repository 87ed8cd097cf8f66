"""The resources of a parametric FMU (``sphrom fmu SCENE --vary c=LO:HI [--vary d=LO:HI]``).

The model of :mod:`sphrom.rom.parametric` is stored as the ordinary kind's
arrays at the start values of c and d (the scene's values, or a range's
midpoint when the scene's value lies outside it) plus tagged sections:
``PARAMS`` (rows c, d: varied 0/1, start, min, max) and the affine pieces,
``KC``, ``BC``, ``DD`` (frozen: K per unit c, b per unit c, D̂ per unit d) or
``A0``, ``AC``, ``AD`` (linear).  The C core assembles K, b, D̂ or A from them
at ExitInitializationMode in the order of :func:`sphrom.rom.parametric.frozen_at`
and :func:`~sphrom.rom.parametric.linear_at`, so that at equal (c, d) the FMU
and the Python model agree bitwise (frozen) or to round-off (exact: the C and
the scipy matrix exponentials differ in the last bits).
"""

from __future__ import annotations

import numpy as np

from ...errors import FieldError
from ...rom import parametric as par
from ...rom.model import basis_modes
from ...rom.registry import get_model
from ...sph.solver import build_problem
from ..kinds import for_model, pack
from ..training.envelope import measure, union
from ..training.steps import shadow_step
from ..variables import number, vr

# How the force profile enters a parametric model's FMU (``input_direction`` of build_operators), by model.
# Frozen: the input row p = U_vᵀ profile, never the profile's residual appended, and the profile's response at
# every frequency (static deflection, in-band moments: "moments") where the modes miss more than 1 % of it,
# except for a rigid profile (sphrom.rom.operators.rigid_profile).  The combined basis of several (c, d) misses
# a little more of the profile than a one-point basis (tenmode, c in [0.05, 0.2], d in [0, 5], k = 12: 1.2 %,
# above the 1 % of the ordinary FMU's "needed" rule), and appending that rough residual raised the probe-velocity
# error at held-out points from at most 0.09 to up to 0.36 (python -m sphrom.bench.parametric --input-direction
# needed).  Along a non-uniform profile the moments are what a constant or an in-band force needs: the profile
# 1 + sin 2πx + ½ cos 6πx, c in [c/2, 2c], a 1e-2 sin 7t force from rest, 10 s, against the linear SPH exact in
# time: worst 0.52 ("project") against 0.024 on tenmode, 0.056 against 0.002 on damped_forced with d in [0, 2d]
# (python -m sphrom.bench.inputs --case parametric-profile-sine --case parametric-damped-profile-sine;
# tests/test_parametric.py checks it at small N).  The exact model keeps its rule (the profile always in the basis).
PARAMETRIC_INPUT_DIRECTION = {"frozen": "moments"}


def params_section(space):
    """The PARAMS section (2, 4): rows c, d; columns varied (0/1), start, min, max."""
    rows = []
    for name in par.PARAMETERS:
        lo, hi = space.bounds(name)
        rows.append([1.0 if space.varies(name) else 0.0, space.start(name), lo, hi])
    return np.array(rows, dtype=float)


def parameter_variables(space):
    """The varied parameters of a parametric FMU, for its summary: dicts name, vr, start, min, max (the
    modelDescription takes them from section PARAMS, :mod:`sphrom.fmu.make.describe`)."""
    out = []
    for name in par.PARAMETERS:
        if not space.varies(name):
            continue
        lo, hi = space.bounds(name)
        out.append({"name": name, "vr": vr(name), "start": number(space.start(name)), "min": number(lo),
                    "max": number(hi)})
    return out


def parametric_model(scene, ranges, k, *, model="frozen", progress=True, input_direction=None):
    """The affine model of ``scene`` over ``ranges`` with k modes: (affine, space, basis, points).

    ``affine`` is :class:`~sphrom.rom.parametric.AffineFrozen` or :class:`~sphrom.rom.parametric.AffineLinear`;
    ``input_direction`` (default :data:`PARAMETRIC_INPUT_DIRECTION`, else the model's FMU rule) as in
    :func:`sphrom.rom.operators.build_operators`.
    """
    spec = get_model(model)
    if not spec.needs_basis:
        raise FieldError("model", f"{model} cannot be made parametric (allowed: a POD model: frozen, exact)")
    space = par.parameter_space(build_problem(scene), ranges)
    points = par.training_points(space)
    basis, _ = par.training_basis(scene, points, progress=progress)
    available = min(spec.available_modes(basis))
    if k > available:
        raise FieldError("k", f"{k} is out of range (allowed: 1 to {available}, the POD modes of the parametric "
                              f"basis)")
    U1, U2 = basis_modes(basis, spec.basis_kind, k, k)
    direction = input_direction or PARAMETRIC_INPUT_DIRECTION.get(model, spec.fmu_input_direction)
    if spec.linear:
        affine = par.affine_linear(scene, space, U1, U2, input_direction=direction)
    else:
        affine = par.affine_frozen(scene, space, U1, U2, input_direction=direction, tensor="always")
    return affine, space, basis, points


def parametric_envelope(scene, space, ops, probes, linear, progress=False):
    """The training envelope (:mod:`sphrom.fmu.training.envelope`) of a parametric model: the union over the full SPH
    runs at every sample point (:func:`sphrom.rom.parametric.training_points`, the runs its basis was made of,
    cached), each projected on the model's basis as the ordinary FMU's (the exact model in the scene's c, in
    which its basis is orthonormal)."""
    problem = build_problem(scene)
    _, runs = par.training_basis(scene, par.training_points(space), progress=progress)
    return union([measure(scene, ops, problem, run, probes, linear) for run in runs])


def parametric_resource(scene, model, k, n_freeze, probes, integrator, progress, ranges, error_bounds=True,
                        integrator_given=True):
    """(data, ops at the start values, resource bytes, space) of a parametric FMU; its training envelope that of
    the runs at all sample points (:func:`parametric_envelope`); with ``error_bounds`` the certified error bounds'
    parametric shadow about the scene's (c, d) (:func:`sphrom.fmu.make.models.shadow_step`; the C core
    assembles its planes at the FMU's c and d).  ``integrator_given`` False: a time-stepped kind's integrator
    chosen for open-ended runs (:func:`sphrom.fmu.kinds.frozen.open_ended_integrator`) at the box's corner where
    explicit Euler grows most (the largest c, the fastest modes; the smallest d)."""
    affine, space, _, _ = parametric_model(scene, ranges, k, model=model, progress=progress)
    c0, d0 = space.start("c"), space.start("d")
    problem = build_problem(scene)
    sections = {"PARAMS": params_section(space)}
    kind = for_model(model)                  # its operators at (c0, d0) and its affine pieces (KC, BC, DD or A0, AC, AD)
    if not integrator_given and "integrator" in kind.BUILD_OPTIONS:
        from ..kinds.frozen import open_ended_integrator
        worst = par.frozen_at(affine, space.bounds("c")[1], space.bounds("d")[0])
        integrator = open_ended_integrator(worst, scene.sph.dt, integrator)
    given = {"dt": scene.sph.dt, "n_freeze": n_freeze, "integrator": integrator}
    data, ops, pieces = kind.parametric(affine, c0, d0, problem, probes=probes,
                                        **{name: given[name] for name in kind.BUILD_OPTIONS})
    sections.update(pieces)
    sections.update(parametric_envelope(scene, space, ops, probes, get_model(model).linear, progress).sections())
    data.sections.update(sections)
    if error_bounds:
        shadow_step(data, ops, problem, probes, parametric=True)
    return data, ops, pack(data), space

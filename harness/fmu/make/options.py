"""Step "options" of ``package_fmu``: every packaging option checked before any work (one FieldError naming the
field and the allowed range)."""

from __future__ import annotations

import math
import sys

import numpy as np

from ... import defaults
from ...errors import FieldError, exact
from ...rom import parametric as par
from ...rom.registry import fmu_model_names, get_model, model_names
from ...sph.ports import parse_ports
from ...sph.solver import build_problem
from ..kinds import for_model
from ..kinds.frozen import FROZEN_INTEGRATORS, PORT_INTEGRATOR, default_integrator  # noqa: F401
from ..resources import MAX_PROBES
from ..variables import check_parameter

from ...pod.pipeline import accel_modes


def default_modes(scene, linear=False):
    """K of the scene: max(rom.accel_modes), else rom.modes, else the automatic mode count of its POD
    (:func:`sphrom.pod.pipeline.scene_modes`: runs the full SPH when it is not cached; ``linear``: for a linear
    model, not capped at :data:`sphrom.pod.automatic.MAX_AUTO_MODES`)."""
    return int(max(accel_modes(scene, linear=linear)))


def parse_probes(text):
    """``0.25,0.5`` -> [0.25, 0.5]; FieldError naming the field ``probes`` when out of range."""
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise FieldError("probes", f"{text!r} is not a comma-separated list of numbers "
                                   f"(allowed: 1 to {MAX_PROBES} positions x/L in [0, 1])") from None
    if not values or len(values) > MAX_PROBES:
        raise FieldError("probes", f"{len(values)} probes (allowed: 1 to {MAX_PROBES} positions x/L in [0, 1])")
    for v in values:
        if not (math.isfinite(v) and 0.0 <= v <= 1.0):
            raise FieldError("probes", f"{v!r} is out of range (allowed: positions x/L in [0, 1])")
    return values


def check_options(scene, *, k=None, n_freeze=defaults.N_FREEZE, probes=defaults.PROBES, fmi=2, integrator=None,
                  model="frozen", tolerance=None, order_tolerance=None, ports=()):
    """Validate the packaging options before any work; returns (k, n_freeze, probes, fmi, integrator).

    For a linear model (the exact one) the integrator is ``exponential`` (an ``integrator`` does not apply).
    Given no ``integrator``, a time-stepped model takes :func:`default_integrator` (with ``ports``: symplectic).
    ``tolerance`` (0 < tolerance < 1) is the largest measured training error accepted (:func:`package_fmu`
    with ``verify``), for every model.  ``order_tolerance`` (0 < order_tolerance < 1) applies to a model whose
    order may come from a tolerance (``sized_by_tolerance``: balanced) given no order ``k`` (1 <= r < 2N); with
    neither, k is returned as None (the order then comes from :data:`sphrom.defaults.ORDER_TOLERANCE`).

    Raises FieldError naming the field (``k``, ``n_freeze``, ``probes``, ``fmi``, ``model``, ``integrator``,
    ``tolerance``, ``order_tolerance``) and the allowed range; the command line shows the option that set it.
    """
    if model not in fmu_model_names():
        raise FieldError("model", f"{model!r} is out of range (allowed: {', '.join(fmu_model_names())})")
    spec = get_model(model)
    for name, value in (("tolerance", tolerance), ("order_tolerance", order_tolerance)):
        if value is not None and (isinstance(value, bool) or not (isinstance(value, (int, float))
                                                                  and math.isfinite(value) and 0 < value < 1)):
            raise FieldError(name, f"{value!r} is out of range (allowed: 0 < {name} < 1)")
    if order_tolerance is not None and not spec.sized_by_tolerance:
        raise FieldError("order_tolerance", f"does not apply to the {model} model, whose size is its POD mode count "
                                            f"k (allowed with: {', '.join(model_names(sized_by_tolerance=True))})")
    if order_tolerance is not None and k is not None:
        raise FieldError("order_tolerance", "give the order k or order_tolerance, not both")
    k = default_modes(scene, linear=spec.linear) if k is None and not spec.sized_by_tolerance else k
    if k is not None and (isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1):
        raise FieldError("k", f"{k!r} is out of range (allowed: an integer >= 1)")
    limit = spec.max_modes(scene.sph.n_particles)
    if k is not None and k > limit:
        raise FieldError("k", f"{k} is out of range (allowed: " + (f"an order r from 1 to 2N - 1 = {limit})"
                                                                    if spec.sized_by_tolerance else
                                                                    f"1 to N = {limit})"))
    # None: chosen per scene at packaging (harness/fmu/make/models.py choose_n_freeze); else the FMU's range
    n_freeze = None if n_freeze is None else int(check_parameter("n_freeze", n_freeze))
    probes = parse_probes(",".join(str(p) for p in probes)) if not isinstance(probes, str) else parse_probes(probes)
    if fmi not in (2, 3):
        raise FieldError("fmi", f"{fmi!r} is out of range (allowed: 2 or 3)")
    kind = for_model(model)                 # the options its model kind takes (its BUILD_OPTIONS)
    if "integrator" not in kind.BUILD_OPTIONS:
        if integrator is not None:
            raise FieldError("integrator", f"{integrator!r} does not apply to the {model} model (it is advanced "
                                           "by the matrix exponential)")
        return None if k is None else int(k), n_freeze, probes, int(fmi), spec.integrators[0]
    integrator = integrator or default_integrator(scene, ports)
    if integrator not in spec.integrators:
        raise FieldError("integrator", f"{integrator!r} is not defined for the {model} model "
                                       f"(allowed: {', '.join(spec.integrators)}; scene '{scene.name}' uses "
                                       f"{scene.sph.integrator})")
    # the C core refuses a dt below the smallest internal step: the work of a doStep grows as 1/dt (rom.h)
    if "dt" in kind.BUILD_OPTIONS and scene.sph.dt < kind.DT_MIN:
        raise FieldError("dt", f"the scene's dt = {scene.sph.dt!r} s is below the smallest internal step a "
                               f"{model} FMU takes, {kind.DT_MIN:g} s (allowed: dt >= {kind.DT_MIN:g} s)")
    return int(k), n_freeze, probes, int(fmi), integrator


def check_ports(ports, model):
    """The port positions (a list, empty for None) of an FMU of ``model``; FieldError naming ``ports`` when bad
    or when the model takes no port forces (the registry's ``ports``)."""
    if ports is None or (not isinstance(ports, str) and len(ports) == 0):
        return []
    ports = parse_ports(ports)
    if not get_model(model).ports:
        raise FieldError("ports", f"the {model} model takes no port forces (allowed with: "
                                  f"{', '.join(n for n in model_names(ports=True) if get_model(n).fmu_kind)})")
    return ports


def check_vary(scene, texts, model):
    """The parameter ranges of a parametric FMU, checked before any run.

    Parameters
    ----------
    scene : Scene
    texts : list of str
        ``c=LO:HI`` / ``d=LO:HI`` (``sphrom fmu --vary``): the uniform stiffness c [kg m^-1 s^-2] or damping d
        [s^-1]; empty for an FMU that is not parametric.
    model : str
        The model to package (one with a POD basis).

    Returns
    -------
    list of sphrom.rom.parametric.Range (empty for no ``texts``)

    Raises
    ------
    FieldError
        ``vary`` for a bad text or a subnormal bound, ``model`` for a model without a POD basis, and
        ``fields.c`` / ``fields.d`` when the scene's field is not uniform.
    """
    if not texts:
        return []
    ranges = [par.parse_vary(text) for text in texts]
    for r in ranges:                    # a subnormal bound keeps a few of its digits: c = 1e-320 is 9.99989e-321
        for bound in (r.lo, r.hi):
            if 0 < bound < sys.float_info.min:
                raise FieldError("vary", f"{r.name} bound {exact(bound)} is below the smallest normal number "
                                         f"{sys.float_info.min:.4g}, where doubles lose their precision (allowed: "
                                         f"{'' if r.name == 'c' else r.name + ' = 0 or '}{r.name} >= "
                                         f"{sys.float_info.min:.4g})")
    if not get_model(model).needs_basis:
        allowed = ", ".join(name for name in fmu_model_names() if get_model(name).needs_basis)
        raise FieldError("model", f"{model} cannot be made parametric (allowed with vary: {allowed})")
    par.parameter_space(build_problem(scene), ranges)
    return ranges


def check_port_spacing(scene, ports):
    """``ports`` (x/L) unless two are closer than one particle spacing L/N on the periodic bar.

    Each port's force is spread over the particles by the SPH kernel, so two ports within one spacing push nearly
    the same particles with nearly the same weights and the model cannot tell their forces (nor their velocities)
    apart; the second one's profile is then almost inside the first one's directions.

    Raises
    ------
    FieldError
        ``ports``, naming the two positions and their gap.
    """
    n = scene.sph.n_particles
    for i, a in enumerate(ports):
        for b in ports[i + 1:]:
            gap = abs(a - b) % 1.0
            gap = min(gap, 1.0 - gap)
            if gap < 1.0 / n:
                raise FieldError("ports", f"{exact(a)} and {exact(b)} are {gap:.3g} L apart, closer than one particle "
                                          f"spacing (1/N = 1/{n} L): the SPH kernel spreads both forces over the same "
                                          "particles, so the model cannot tell them apart (allowed: ports at least "
                                          "L/N apart)")
    return ports

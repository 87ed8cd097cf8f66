"""The FMU's model kinds: one module per kind of ``resources/model.bin``, as the C core has one table of operations
per kind (fmu_src/rom_internal.h ``RomKindOps``; fmu_src/rom_frozen.c, rom_exact.c).

A kind module owns everything that differs between kinds on the Python side: its data class (what its model.bin
holds), its part of the file (:func:`file_fields`, :func:`from_file`; the shared header, sections, token and checksum
are :mod:`sphrom.fmu.resources`'), its build options and its packaging step (``resource``), its co-simulation in
Python that the C core must equal, its words on the FMU's pages and the facts the variable table needs.  Code
elsewhere asks the kind of a model (:func:`kind_of` its data, :func:`by_number` the header's model_kind,
:func:`for_model` a registry model's ``fmu_kind``), never the data's class.

:func:`pack` and :func:`unpack` read and write any kind's model.bin: the kind gives its part, the shared header,
sections, token and checksum are :func:`sphrom.fmu.resources.write` and :func:`sphrom.fmu.resources.read`.

The table is :data:`sphrom.fmu.layout.KINDS` (the bytes' spec): kind ``name`` is the module ``sphrom.fmu.kinds.<name>``.
A new kind is a row there, its module here and its C file (docs/internals/c-code.md).

Each kind module defines::

    NUMBER                  the header's model_kind
    Data                    its data class (class attribute KIND = NUMBER)
    BUILD_OPTIONS           the packaging options it takes (frozen: n_freeze, dt, integrator)
    INTERNAL_STEP           it advances by internal steps of dt (the FMU parameters n_freeze, dt: the variable
                            table's rule ``frozen``, sphrom.fmu.variables.facts; C rom_has_internal_step)
    INITIAL_STATE           the array initial_state_scale multiplies (a_v0, z0)
    OUTPUT_DERIVATIVE_ORDER the output derivatives it gives (maxOutputDerivativeOrder)
    MODELS                  {registry model name: ModelWords}: the words of each model of this kind
    file_fields(data)       (shared header fields, its own header or None, {array name: array}) for pack
    from_file(header, head, arrays, token, sections) -> Data
    min_k_rho(flags)        the smallest k_rho its header may have
    from_operators(ops, problem, *, probes, **build options) -> Data
    resource(scene, model, k, n_freeze, probes, integrator, progress, problem, **options) -> (data, ops, blob)
    parametric(affine, c, d, problem, *, probes, **build options) -> (data, ops, its affine sections)
    model_name(data)        the registry model the data holds
    integrator(data)        the name of its time integrator where it has one (None: exact in time)
    parameter_starts(data)  the start values of its own FMU parameters (frozen: n_freeze, dt)
    stepping(data)          modelDescription's words on its time stepping
    model_rows(data)        the documentation page's rows on it
    usage(data)             the documentation page's sentence on how it steps
    example(rng)            a small model of the kind with random numbers (tests of the file and the core)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import import_module

from .. import layout
from ..resources import read, write

# doStep's rules on the time, the same for every kind (fmu_src/rom.h, rom.c check_step, rom_internal.h
# rom_same_step): every tolerance is the time's own rounding or the step's, never one that grows with |t|, so an
# FMU started at 1.7e9 s steps as one started at 0.
TIME_ULPS = 16.0                # ROM_TIME_ULPS: currentCommunicationPoint equals the FMU's time to this many ulps ...
TIME_STEP_TOLERANCE = 1e-9      # ROM_TIME_STEP_TOLERANCE: ... plus this x the step h
SAME_STEP = 1e-9                # ROM_SAME_STEP: two step lengths within this x the step are one (the cached maps)
_EPS = 2.220446049250313e-16    # the double's machine epsilon (C's DBL_EPSILON)


def step_error(time, t_comm, h, elapsed=0.0):
    """The rule ``doStep(t_comm, h)`` breaks at the FMU's time ``time`` [s] (``elapsed`` [s] since its start), in
    the C core's words (fmu_src/rom.c check_step), or None when the step is taken.

    t_comm finite; h finite and > 0; |t_comm - time| within TIME_ULPS units in the last place of the larger |t|
    plus TIME_STEP_TOLERANCE h; t_comm + h (and elapsed + h) finite and later than t_comm.
    """
    if not math.isfinite(t_comm):
        return f"currentCommunicationPoint = {_g(t_comm)} is not finite"
    if not (math.isfinite(h) and h > 0):
        return (f"communicationStepSize = {_g(h)} s at t = {t_comm:.17g} s is out of range (allowed: a finite number "
                "> 0)")
    ulps = TIME_ULPS * _EPS * max(abs(t_comm), abs(time))
    if not abs(t_comm - time) <= ulps + TIME_STEP_TOLERANCE * h:
        return (f"currentCommunicationPoint = {t_comm:.17g} s does not match the FMU's time {time:.17g} s (allowed: "
                f"equal to within {TIME_ULPS:.0f} units in the last place, plus {_g(TIME_STEP_TOLERANCE)} of the "
                "step)")
    t_new = t_comm + h
    if not (math.isfinite(t_new) and math.isfinite(elapsed + h)):
        return (f"communicationStepSize = {_g(h)} s at t = {t_comm:.17g} s takes the time beyond the largest number "
                "(t + h is not finite)")
    if not t_new > t_comm:
        return (f"communicationStepSize = {_g(h)} s at t = {t_comm:.17g} s is below the time's resolution there "
                f"({_g(math.nextafter(abs(t_comm), math.inf) - abs(t_comm))} s): t + h would equal t")
    return None


def same_step(h, h_cached):
    """Whether a step of length ``h`` [s] is the cached one ``h_cached`` (fmu_src/rom_internal.h rom_same_step):
    equal, or within SAME_STEP of it relative to the step."""
    if h == h_cached:
        return True
    return h_cached > 0.0 and abs(h - h_cached) <= SAME_STEP * h_cached


def _g(x):
    """``x`` as C's %g prints it (inf, nan as C does)."""
    return "%g" % x if math.isfinite(x) else ("nan" if math.isnan(x) else ("inf" if x > 0 else "-inf"))


@dataclass(frozen=True)
class ModelWords:
    """What one registry model of a kind is, in words (the FMU's page, the README's model table).

    ports : str
        What it represents of a mechanical port exactly, and what it approximates (docs/fmu/ports.md).
    what, limits, when : str
        The README model table's columns (:mod:`sphrom.docs_figures`): what it represents exactly, its limits,
        when to use it.
    """

    ports: str
    what: str
    limits: str
    when: str


def kinds():
    """{model_kind: kind module} in the order of ``layout.KINDS``."""
    return {k.number: import_module(f"{__name__}.{k.name}") for k in layout.KINDS}


def by_number(number):
    """The kind module of the header's model_kind ``number`` (ValueError naming the known ones)."""
    spec = layout.KIND_BY_NUMBER.get(number)
    if spec is None:
        raise ValueError(f"model kind {number!r} (allowed: {', '.join(str(k.number) for k in layout.KINDS)})")
    return import_module(f"{__name__}.{spec.name}")


def kind_of(data):
    """The kind module of ``data`` (a kind's data class: its KIND)."""
    return by_number(type(data).KIND)


def pack(data) -> bytes:
    """The bytes of model.bin of ``data`` (any kind's data class); sets ``data.token``.

    The kind gives its header fields, its own header and its arrays (:func:`sphrom.fmu.kinds.frozen.file_fields`,
    ...); :func:`sphrom.fmu.resources.write` checks the arrays against the shapes of ``layout.KINDS`` and writes
    them in that order."""
    kind = kind_of(data)
    header, head, arrays = kind.file_fields(data)
    blob, data.token = write(layout.KIND_BY_NUMBER[kind.NUMBER], header, head, arrays, data.sections,
                             min_k_rho=kind.min_k_rho(header["flags"]))
    return blob


pack_exact = pack          # its former name for the linear models' files


def unpack(blob: bytes):
    """Read model.bin bytes back (:func:`sphrom.fmu.resources.read`: the checks of the C loader that concern the
    layout): the kind's data class."""
    spec, header, head, arrays, token, sections = read(blob)
    return by_number(spec.number).from_file(header, head, arrays, token, sections)


def for_model(name):
    """The kind module of the registered reduced model ``name`` (its ``fmu_kind``); ValueError when it has none."""
    from ...rom.registry import get_model
    spec = get_model(name)
    if spec.fmu_kind is None:
        raise ValueError(f"reduced model {name!r} cannot be packaged as an FMU")
    return by_number(spec.fmu_kind)


def model_words():
    """{registry model name: ModelWords} of every kind's models, in the kinds' order."""
    return {name: words for kind in kinds().values() for name, words in kind.MODELS.items()}

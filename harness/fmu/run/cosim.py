"""``sphrom cosim``: an sphrom FMU co-simulated on the one FMU driver (:mod:`sphrom.fmu.run.driver`).

The input f(t) is an expression in t (and T, the end time) or a CSV file with
columns ``time,f``, sampled at the communication points (a CSV interpolated
linearly between its rows).  One rule (docs/fmu/cosim.md): f goes linearly
over each step where the FMU declares it can take input derivatives (FMI 2
``canInterpolateInputs``: f at the point and df/dt, the slope to the next
one), and is held over each step otherwise or with ``hold_inputs``.  FMI 3.0
co-simulation has no input derivatives (its intermediate update, which these
FMUs do not provide, is the mechanism for inputs inside a step), so an FMI 3
FMU holds f.  The result has the time and every output of the FMU at the
communication points.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import defaults
from ...errors import FieldError, SimulationError, UserError, exact
from ...paths import exists, is_file, not_a_file
from ..variables import absent, check_parameter
from .driver import can_interpolate_inputs


@dataclass
class CosimResult:
    """Outputs at the communication points.

    Attributes
    ----------
    names : list of str
        ``time`` and the output names.
    values : ndarray (M, len(names))
        time [s], v_probe_* [m s^-1], rho_probe_* [kg m^-3].
    wall_time : float
        Wall time of the co-simulation [s] (extraction, instantiation, the loop, freeing).
    steps : int
        Communication steps.
    input_derivatives : bool
        Whether df/dt was passed with fmi2SetRealInputDerivatives (else f held over each step).
    warnings : list of str
        The FMU's logged warnings (e.g. leaving its training envelope).
    """

    names: list
    values: np.ndarray
    wall_time: float
    steps: int
    input_derivatives: bool = False
    warnings: list = field(default_factory=list)


def read_fmu_description(path):
    """fmpy's model description of an sphrom FMU; FieldError ``fmu`` when it is not one."""
    from fmpy import read_model_description
    path = Path(path)
    if not is_file(path):
        raise FieldError("fmu", f"'{path}': {not_a_file(path)}")
    from .driver import check_archive
    check_archive(path)                 # names, sizes (a zip bomb's modelDescription.xml is not read)
    try:
        md = read_model_description(str(path))
    except Exception as exc:            # fmpy raises plain exceptions for bad archives
        raise FieldError("fmu", f"'{path}': not a readable FMU ({str(exc).splitlines()[0]})") from None
    if md.coSimulation is None or md.coSimulation.modelIdentifier != "sphrom":
        raise FieldError("fmu", f"'{path}': not an sphrom co-simulation FMU (modelIdentifier sphrom)")
    return md


def force_signal(force, t_end, step):
    """The input signal (structured array time, f) for fmpy, or None without a force.

    ``force`` is an expression in t and T (T = t_end), sampled at the
    communication points, or the path of a CSV file with columns time,f: a
    CSV when it ends in ``.csv`` or names an existing path, else an
    expression (also when it is no possible file name: too long, a NUL).
    Raises FieldError ``force`` when it cannot be read or evaluated or is not finite, or
    when a CSV has fewer than two rows or its times do not cover [0, t_end].
    """
    if force is None:
        return None
    text = str(force).strip()
    path = Path(text)
    if text.lower().endswith(".csv") or exists(path):      # a folder or FIFO by that name: said so, not parsed
        signal = _csv_signal(path)
        check_coverage(signal, path, 0.0, t_end)
        input_samples(signal, signal["time"])          # f is interpolated between rows: finite slopes
        return signal
    from ...expr import compile_expr
    try:
        expr = compile_expr(text, ("t", "T"), "force")
    except UserError as exc:             # "force: <what is wrong>"
        raise FieldError("force", str(exc).split(": ", 1)[-1]) from None
    n = int(round(t_end / step))
    times = np.arange(n + 1) * step
    if times[-1] < t_end - 1e-9 * step:                  # a remainder of a billionth of a step is none
        times = np.append(times, t_end)
    times[-1] = min(times[-1], t_end)
    try:
        with np.errstate(all="ignore"):
            values = np.broadcast_to(expr(t=times, T=t_end), times.shape).astype(float)
    except UserError as exc:
        raise FieldError("force", str(exc).split(": ", 1)[-1]) from None
    except (ValueError, TypeError, ZeroDivisionError) as exc:
        raise FieldError("force", f"cannot evaluate {text!r} ({exc})") from None
    bad = ~np.isfinite(values)
    if np.any(bad):
        raise FieldError("force", f"{text!r} is not finite at t = {times[bad][0]:g} s (allowed: a finite force)")
    signal = np.zeros(times.size, dtype=[("time", np.float64), ("f", np.float64)])
    signal["time"], signal["f"] = times, values
    input_samples(signal, times)
    return signal


def input_samples(signal, times):
    """f at the communication points ``times`` (the signal interpolated linearly, held outside) and the
    forward slopes df/dt over each step [m s^-3] (len(times) - 1 values)."""
    with np.errstate(all="ignore"):
        f = np.interp(times, signal["time"], signal["f"])
        rate = np.diff(f) / np.diff(times)
    bad = ~np.isfinite(rate)
    if np.any(bad) or not np.all(np.isfinite(f)):
        j = int(np.argmax(bad)) if np.any(bad) else 0
        raise FieldError("force", f"f goes from {f[j]:.6g} to {f[j + 1]:.6g} m s^-2 between t = {times[j]:g} and "
                                  f"{times[j + 1]:g} s: its slope df/dt overflows (allowed: a force whose slope "
                                  "between samples is finite, |df/dt| <= 1.8e308 m s^-3)")
    return f, rate


def _not_instantiable(fmu, exc):
    """FieldError ``fmu`` with the FMU's own logged reason for a failed instantiate (a bad file is the user's):
    ``exc`` the driver's :class:`~sphrom.fmu.run.driver.InstantiateError`."""
    return FieldError("fmu", f"'{fmu}' cannot be instantiated: {exc.detail}")


def _csv_signal(path):
    if not is_file(path):
        raise FieldError("force", f"CSV file '{path}': {not_a_file(path)}")
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:        # a byte-order mark is no column name
            reader = csv.reader(fh)
            header = [h.strip() for h in next(reader)]
            rows = [row for row in reader if row and any(c.strip() for c in row)]
    except (OSError, StopIteration, UnicodeDecodeError, csv.Error) as exc:
        raise FieldError("force", f"cannot read CSV file '{path}' ({exc or 'empty'})") from None
    if sorted(header) != ["f", "time"]:         # an extra column would be dropped without a word
        raise FieldError("force", f"'{path}' has the columns {','.join(header)} (allowed: exactly time,f)")
    it, jf = header.index("time"), header.index("f")
    for i, row in enumerate(rows):
        if len(row) != 2:
            raise FieldError("force", f"'{path}': data row {i + 1} has {len(row)} values (allowed: two, time,f)")
    try:
        data = np.array([(float(r[it]), float(r[jf])) for r in rows], dtype=float).reshape(-1, 2)
    except (ValueError, IndexError):
        raise FieldError("force", f"'{path}' has a row that is not two numbers time,f") from None
    if data.shape[0] == 0:
        raise FieldError("force", f"'{path}' has no rows")
    if not np.all(np.isfinite(data)):
        raise FieldError("force", f"'{path}' has non-finite values (allowed: finite time and f)")
    steps = np.diff(data[:, 0])
    if np.any(steps <= 0):                      # a repeated time gives f two values there
        i = int(np.argmax(steps <= 0))
        what = "repeats" if steps[i] == 0 else "goes back to"
        raise FieldError("force", f"'{path}': data row {i + 2} {what} t = {float(data[i + 1, 0])!r} s (allowed: times "
                                  "increasing, one f per time)")
    signal = np.zeros(data.shape[0], dtype=[("time", np.float64), ("f", np.float64)])
    signal["time"], signal["f"] = data[:, 0], data[:, 1]
    return signal


def check_coverage(signal, path, start, t_end):
    """FieldError ``force`` unless the CSV signal has two rows or more and its times cover [start, t_end] [s]
    (f is never held silently beyond the last row, nor before the first)."""
    times = signal["time"]
    allowed = f"(allowed: at least two rows whose times cover [{start:g}, {t_end:g}] s)"
    if times.size < 2:
        raise FieldError("force", f"'{path}' has {times.size} row {allowed}")
    if times[-1] < 0:
        raise FieldError("force", f"'{path}' has only negative times (last {times[-1]:g} s) {allowed}")
    tol = 1e-12 * max(abs(t_end), abs(start))            # relative: a bar's times may be microseconds
    if times[0] > start + tol or times[-1] < t_end - tol:
        raise FieldError("force", f"'{path}' covers [{exact(times[0])}, {exact(times[-1])}] s, not [{exact(start)}, "
                                  f"{exact(t_end)}] s "
                         f"{allowed}")


# At most this many communication steps in one co-simulation: the output table holds one row per step
# (1e8 rows x the outputs x 8 bytes is already gigabytes).
MAX_COMM_STEPS = 100_000_000


def _positive(value, field):
    if value is None:
        return None
    if not (math.isfinite(value) and value > 0):
        raise FieldError(field, f"{value!r} is out of range (allowed: a finite number > 0)")
    return float(value)


def _experiment(md, fmu, attribute, field):
    """The FMU's DefaultExperiment ``attribute`` (stopTime, stepSize) [s]: FieldError ``fmu`` naming it and the
    field (``t_end``, ``step``) that replaces it when it is missing, not a number, not finite or not > 0."""
    value = getattr(md.defaultExperiment, attribute, None) if md.defaultExperiment is not None else None
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number > 0):
        shown = "missing" if value is None else f"{value!r}" if isinstance(value, str) else exact(number)
        raise FieldError("fmu", f"'{fmu}': its DefaultExperiment {attribute} is {shown} (allowed: a finite number "
                                f"> 0 [s]; or give {field})")
    return number


# bytes per value of the output table over its life: the times, the outputs fmpy collects, the table with the
# time column, and the CSV writer's row (measured: a 1e6-step run of a 7-output FMU peaks at ~3.5 x its table)
TABLE_COPIES = 4


def check_table_memory(md, fmu, steps, field, what):
    """FieldError ``field`` when the run's output table (``steps`` + 1 rows of time and every output, float64,
    :data:`TABLE_COPIES` times over) would not fit in the memory this machine has available
    (:func:`sphrom.runio.available_memory`), before any step is taken."""
    from ...runio import available_memory, format_bytes
    outputs = sum(1 for v in md.modelVariables if v.causality == "output")
    need = (steps + 1) * (outputs + 1) * 8 * TABLE_COPIES
    free = available_memory()
    if free is not None and need > free:
        raise FieldError(field, f"{what} gives {steps + 1:.3g} rows of {outputs + 1} columns, about "
                                f"{format_bytes(need)} of memory, and this machine has {format_bytes(free)} "
                                f"available (allowed: at most {max(free // ((outputs + 1) * 8 * TABLE_COPIES) - 1, 1):.3g} "
                                "communication steps here)")


def has_parameter(md, fmu, name, why=None):
    """FieldError naming ``name`` when the FMU ``fmu`` (its model description ``md``) has no such parameter: a
    start value for it would be ignored (:func:`sphrom.fmu.variables.absent`)."""
    if not any(v.name == name for v in md.modelVariables):
        raise absent(name, f"'{fmu}'", why)


def run_cosim(fmu, force=None, t_end=None, step=None, n_freeze=None, hold_inputs=False,
              initial_state_scale=None) -> CosimResult:
    """Co-simulate ``fmu`` on the FMU driver (module docstring: the input rule).

    Parameters
    ----------
    fmu : path
        An sphrom FMU (FMI 2.0 or 3.0).
    force : str, optional
        Expression in t, T [m s^-2] or a CSV file time,f (default f = 0).
    t_end : float, optional
        End time [s] (default the DefaultExperiment's stopTime).
    step : float, optional
        Communication step [s] (default its stepSize).
    n_freeze : int, optional
        The ``n_freeze`` parameter (default the packaged one); FieldError for an FMU without it (the linear
        models: no internal step).
    hold_inputs : bool
        Hold f over each step even when the FMU can take input derivatives (default: an FMU
        that declares canInterpolateInputs, FMI 2, gets df/dt, f going linearly between the samples).
    initial_state_scale : float, optional
        The ``initial_state_scale`` parameter (default the FMU's start value: 0, at rest; 1 starts
        from the scene's initial state).

    Raises
    ------
    FieldError
        A bad value of ``fmu`` (also: an FMU that fails to instantiate, with the reason it
        logged), ``force``, ``t_end``, ``step``, ``n_freeze`` or ``initial_state_scale``.
    SimulationError
        The FMU reported an error (its message is included).
    """
    md = read_fmu_description(fmu)
    given_end, given = t_end is not None, step is not None
    t_end = _positive(t_end, "t_end") or _experiment(md, fmu, "stopTime", "t_end")
    step = _positive(step, "step") or _experiment(md, fmu, "stepSize", "step")
    # a step that came from the FMU is named as the FMU's, never as an option the user did not give
    field, what = ("step", exact(step)) if given else ("fmu", f"'{fmu}': its DefaultExperiment stepSize {exact(step)}")
    if step > t_end:
        raise FieldError(field, f"{what} is out of range (allowed: 0 < step <= t_end = {exact(t_end)})")
    ratio = t_end / step                # may be inf (t_end 1e308, step tiny): compared before int()
    if ratio > MAX_COMM_STEPS and given_end and not given:     # the end the user gave, at the FMU's own step
        raise FieldError("t_end", f"{exact(t_end)} gives {ratio:.3g} communication steps of the FMU's "
                                  f"DefaultExperiment stepSize {exact(step)} s (allowed: t_end <= 1e8 x step = "
                                  f"{step * MAX_COMM_STEPS:g} s, at most 1e8 steps; or a longer step)")
    if ratio > MAX_COMM_STEPS:
        raise FieldError(field, f"{what} gives {ratio:.3g} communication steps to t_end = {t_end:g} s "
                                f"(allowed: step >= t_end / 1e8 = {t_end / MAX_COMM_STEPS:g} s, at most 1e8 steps)")
    steps = int(math.ceil(ratio - 1e-9))
    check_table_memory(md, fmu, steps, field, what)
    start = {}
    if n_freeze is not None:
        has_parameter(md, fmu, "n_freeze")
        start["n_freeze"] = check_parameter("n_freeze", n_freeze)
    if initial_state_scale is not None:
        if isinstance(initial_state_scale, bool) or not isinstance(initial_state_scale, (int, float)) \
                or not abs(initial_state_scale) <= defaults.MAX_INITIAL_STATE_SCALE:
            raise FieldError("initial_state_scale", f"{exact(initial_state_scale)} is out of range (allowed: "
                             f"[-{defaults.MAX_INITIAL_STATE_SCALE:g}, {defaults.MAX_INITIAL_STATE_SCALE:g}]; 1 the "
                             "scene's initial state, 0 at rest)")
        has_parameter(md, fmu, "initial_state_scale", "an FMU made by an older sphrom: it always starts from the "
                                                      "scene's initial state")
        start["initial_state_scale"] = float(initial_state_scale)
    signal = force_signal(force, t_end, step)
    derivatives = can_interpolate_inputs(md) and not hold_inputs and signal is not None
    times = np.minimum(np.arange(steps + 1) * step, t_end)
    inputs = {} if signal is None else {"f": input_samples(signal, times)[0]}
    from fmpy.fmi1 import FMICallException
    t0 = time.perf_counter()
    fmu_ = _open(fmu)
    with fmu_:
        try:
            fmu_.initialize(parameters=start, inputs={"f": inputs["f"][0]} if inputs else None)
            values = fmu_.simulate(times, inputs, rates=derivatives)
        except FMICallException as exc:
            detail = "; ".join(fmu_.errors()) or str(exc)
            raise SimulationError(f"the FMU failed: {detail}") from None
        warnings = fmu_.warnings()
    names = ["time"] + fmu_.outputs
    return CosimResult(names=names, values=np.column_stack([times, values]), wall_time=time.perf_counter() - t0,
                       steps=steps, input_derivatives=derivatives, warnings=warnings)


def _open(path):
    """The :class:`~sphrom.fmu.run.driver.FMU` of ``path``; FieldError ``fmu`` with the FMU's own logged reason
    when it fails to instantiate (a bad file is the user's)."""
    from .driver import FMU, InstantiateError
    try:
        return FMU(path)
    except InstantiateError as exc:
        raise _not_instantiable(path, exc) from None


def write_csv(path, result: CosimResult):
    """Write ``result`` as CSV (full double precision), atomically."""
    from ...runio import atomic_path
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(result.names)
            for row in result.values:
                writer.writerow([repr(float(x)) for x in row])

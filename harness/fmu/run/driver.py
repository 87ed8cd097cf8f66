"""The one driver of an sphrom FMU from Python (FMI 2.0 and 3.0, through fmpy's classes).

Every loop in sphrom that steps an FMU goes through :class:`FMU` and its :meth:`FMU.simulate`: ``sphrom cosim``,
the verification of ``sphrom fmu``, the sweeps' workers and every benchmark program.  (The tests also drive the
FMUs through ``fmpy.simulate_fmu`` and fmpy's classes directly, as importers nobody here wrote.)

What it does::

    fmu = FMU(path)                              # extract (a .fmu) or use a folder, load, instantiate, capture the log
    fmu.initialize(parameters={"initial_state_scale": 1.0}, inputs={"f": 0.0})
    y = fmu.simulate(times, inputs={"f": f}, rates=True)   # outputs (M+1, n) at the communication points
    fmu.close()

Inputs: values at the communication points, held over each step (``rates`` False), or linear over each step
(``rates`` True, or the names to interpolate): f(t_j + tau) = f_j + (f_{j+1} - f_j)/(t_{j+1} - t_j) tau, passed
as input derivatives (fmi2SetRealInputDerivatives, order 1), which only an FMI 2 FMU that declares
``canInterpolateInputs`` takes (:attr:`FMU.can_interpolate_inputs`).  FMI 3.0 co-simulation has no input
derivatives: its mechanism for inputs inside a step is intermediate update (``providesIntermediateUpdate``),
which these FMUs do not provide, so an FMI 3 FMU always holds its inputs (docs/fmu/cosim.md).  A closed loop
(an input computed from the outputs, e.g. a coupled component) passes ``feedback(j, t_j, y_j) -> {name: value}``.

The loop sets inputs, derivatives, steps and reads outputs through preallocated ctypes arrays and fmpy's raw
function bindings (which still check every status), so its own cost per step is a few microseconds; a status
above warning raises fmpy's ``FMICallException`` and :meth:`FMU.errors` holds the FMU's logged reason.
"""

from __future__ import annotations

import ctypes
import shutil
import threading
from pathlib import Path

import numpy as np

from .. import layout
from ..variables import absent, lookup, vr

# fmpy's FMU constructors chdir() into binaries/<platform> to load the library
# and chdir() back: the working directory is per process, so two threads that
# construct at once can leave the process in another instance's (later deleted)
# folder.  Every construction of an fmpy FMU object in sphrom goes through this.
FMPY_LOAD_LOCK = threading.Lock()
# fmpy's FMI 2 logger proxy (fmpy/logging: it formats the variadic message, then calls the Python logger) keeps
# ONE logger per process in a C global, the last one registered, and every FMI 2 instance of the process that
# uses the proxy (fmpy.simulate_fmu's, fmpy's default callbacks) logs through it.  A per-instance Python callback
# there dies with its instance and leaves the next FMU's log call jumping into freed memory.  So the callback
# registered is one for the process (made once, never freed), and it dispatches each message by the instance's
# componentEnvironment to the live FMU object, or to fmpy's own printer for instances that are not ours.
_INSTANCES = {}
_LOGGER = []


def _register(fmu):
    """The componentEnvironment of ``fmu``'s FMI 2 log messages (its id: unique among live instances)."""
    key = id(fmu)
    _INSTANCES[key] = fmu
    return key


class InstantiateError(RuntimeError):
    """fmi2Instantiate / fmi3InstantiateCoSimulation returned no instance (the C core refused the model: a damaged
    or foreign model.bin, a layout it does not know).  ``reasons``: the FMU's own logged errors (empty when it
    logged none); the message names them, or fmpy's text."""

    def __init__(self, reasons, fallback):
        self.reasons = [" ".join(str(r).split()) for r in reasons]
        self.detail = "; ".join(self.reasons) or str(fallback).splitlines()[0]
        super().__init__("the FMU did not instantiate: " + self.detail)


def fmi2_logger(callback_type):
    """The process's FMI 2 logger callback (made on first use and kept for the process: fmpy's proxy holds it)."""
    if not _LOGGER:
        def log(environment, instance_name, status, category, message):
            fmu = _INSTANCES.get(environment)
            if fmu is not None:
                fmu._keep(status, category, message)
                return
            from fmpy.fmi2 import printLogMessage
            printLogMessage(environment, instance_name, status, category, message)
        _LOGGER.append(callback_type(log))
    return _LOGGER[0]


STATE_HEADER_SIZE = layout.STATE_HEADER.size   # ROM_STATE_HEADER_SIZE (harness/fmu/layout.py): magic to f


def load_fmu(fmi, unzipdir, token, name):
    """An fmpy FMU2Slave / FMU3Slave of an extracted sphrom FMU (library loaded, not instantiated).

    The one place sphrom constructs fmpy FMU objects: it holds :data:`FMPY_LOAD_LOCK`.
    """
    if fmi == 2:
        from fmpy.fmi2 import FMU2Slave as cls
    else:
        from fmpy.fmi3 import FMU3Slave as cls
    with FMPY_LOAD_LOCK:
        return cls(guid=token, unzipDirectory=str(unzipdir), modelIdentifier="sphrom", instanceName=name)


def state_coordinates(blob: bytes, k: int):
    """The k reduced coordinates (a^v then a^ρ, or a then b for the exact model) of a serialized FMU state."""
    return np.frombuffer(blob, dtype="<f8", count=k, offset=STATE_HEADER_SIZE).copy()


# An FMU archive is checked before anything of it is read or extracted: a zip bomb (2 MB that
# unpack to 2 GiB) was extracted in full, an absolute or '..' member name wrote outside the folder, a member
# whose CRC is wrong or a truncated binary (SIGBUS once mapped) killed the process.  sphrom's FMUs unpack to a
# few MiB; the limits leave room for far larger models.
MAX_UNPACKED = 512 * 2**20            # bytes, all members together
MAX_MEMBERS = 10_000
BINARY = {2: "binaries/linux64/sphrom.so", 3: "binaries/x86_64-linux/sphrom.so"}


def _fmu_error(path, detail):
    from ...errors import FieldError
    return FieldError("fmu", f"'{path}': {detail}")


def check_archive(path):
    """The members of the FMU archive ``path`` (zipfile infos), after checking every name (relative, inside
    the archive's folder), the count and the total unpacked size (at most :data:`MAX_UNPACKED`); FieldError
    ``fmu`` naming the problem.  Sizes are the archive's declared ones: :func:`extract_fmu` holds each member
    to its declared size and CRC while it unpacks."""
    import posixpath
    import zipfile
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        raise _fmu_error(path, f"not a readable FMU (a zip archive: {exc})") from None
    if len(infos) > MAX_MEMBERS:
        raise _fmu_error(path, f"has {len(infos)} members (allowed: at most {MAX_MEMBERS})")
    total = 0
    for info in infos:
        name = info.filename
        norm = posixpath.normpath(name.replace("\\", "/"))
        if (name.startswith(("/", "\\")) or (len(name) > 1 and name[1] == ":") or norm == ".."
                or norm.startswith("../") or "\0" in name):
            raise _fmu_error(path, f"member {name[:80]!r} would be unpacked outside its folder (allowed: relative "
                                   "names inside the archive)")
        total += info.file_size
    if total > MAX_UNPACKED:
        raise _fmu_error(path, f"unpacks to {total / 2**20:.4g} MiB (allowed: at most {MAX_UNPACKED // 2**20} MiB: "
                               "an sphrom FMU is a few MiB; this looks like a zip bomb)")
    return infos


def extract_fmu(path):
    """Unpack the FMU archive ``path`` into a new temporary folder (its path) after :func:`check_archive`,
    each member held to its declared size and CRC; on any problem the folder is removed and FieldError ``fmu``
    says what was wrong."""
    import tempfile
    import zipfile
    infos = check_archive(path)
    folder = tempfile.mkdtemp(prefix="sphrom-fmu-")
    try:
        with zipfile.ZipFile(path) as zf:
            for info in infos:
                target = Path(folder, info.filename)
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                written = 0
                with zf.open(info) as src, open(target, "wb") as dst:
                    while chunk := src.read(1 << 20):
                        written += len(chunk)
                        if written > info.file_size:
                            raise _fmu_error(path, f"member {info.filename!r} unpacks to more than its declared "
                                                   f"{info.file_size} bytes")
                        dst.write(chunk)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, NotImplementedError, ValueError) as exc:
        shutil.rmtree(folder, ignore_errors=True)
        raise _fmu_error(path, f"a damaged archive ({exc})") from None
    except OSError as exc:
        shutil.rmtree(folder, ignore_errors=True)
        raise _fmu_error(path, f"cannot be unpacked ({exc.strerror or exc})") from None
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return folder


def check_binary(path, unzipdir, fmi):
    """FieldError ``fmu`` unless the FMU's binary for this platform is there and is a whole x86-64 ELF shared
    library: its header, and every segment to be mapped, inside the file (a truncated library is refused
    before it is mapped; mapped, its missing pages were SIGBUS)."""
    import struct
    rel = BINARY[fmi]
    lib = Path(unzipdir, rel)
    if not lib.is_file():
        raise _fmu_error(path, f"has no binary for this platform ({rel} missing)")
    data = lib.read_bytes()
    size = len(data)
    if size < 64 or data[:4] != b"\x7fELF":
        raise _fmu_error(path, f"{rel} is not a shared library ({size} bytes, no ELF header)")
    if data[4] != 2 or data[5] != 1:
        raise _fmu_error(path, f"{rel} is not a 64-bit little-endian library")
    e_type, e_machine = struct.unpack_from("<HH", data, 16)
    if e_type != 3 or e_machine != 62:
        raise _fmu_error(path, f"{rel} is not an x86-64 shared library (ELF type {e_type}, machine {e_machine})")
    e_phoff, e_shoff = struct.unpack_from("<QQ", data, 32)
    e_phentsize, e_phnum, e_shentsize, e_shnum = struct.unpack_from("<HHHH", data, 54)
    if e_phoff + e_phnum * e_phentsize > size or e_shoff + e_shnum * e_shentsize > size or e_phentsize < 56:
        raise _fmu_error(path, f"{rel} is truncated or damaged (its headers reach past its {size} bytes)")
    for i in range(e_phnum):
        p_type, _, p_offset, _, _, p_filesz = struct.unpack_from("<IIQQQQ", data, e_phoff + i * e_phentsize)
        if p_type == 1 and p_offset + p_filesz > size:          # PT_LOAD
            raise _fmu_error(path, f"{rel} is truncated ({size} bytes; a segment to be loaded reaches to byte "
                                   f"{p_offset + p_filesz})")
    return lib


def can_interpolate_inputs(md) -> bool:
    """Whether an FMU (its fmpy model description ``md``) takes input derivatives: FMI 2 with
    canInterpolateInputs.  FMI 3.0 co-simulation has no input derivatives (module docstring)."""
    return md.fmiVersion == "2.0" and bool(md.coSimulation.canInterpolateInputs)


def _vrs(values):
    return (ctypes.c_uint32 * len(values))(*values)


class FMU:
    """One instantiated sphrom FMU (module docstring).

    Parameters
    ----------
    path : path
        The .fmu file or a folder it was extracted to.
    name : str
        Instance name.
    logging : bool
        ``loggingOn`` at instantiation (the logEvents category).
    token : str, optional
        GUID / instantiationToken to pass (default the model description's).
    messages : list, optional
        Where to keep the log (pass one to read why an instantiation failed).

    Attributes
    ----------
    fmi : int
        2 or 3.
    md : fmpy ModelDescription
    vr : dict
        Value reference of each variable name of this FMU.
    inputs, outputs : list of str
        Input names (f, then F_port_*), output names (v_probe_*, rho_probe_*, then v_port_*).
    messages : list of (status, category, text)
        What the FMU logged.
    instantiate_s : float
        Wall time of loading the library and instantiating [s].

    Raises
    ------
    Exception
        fmpy's, when instantiation fails (the FMU's reason is in ``messages``).
    """

    def __init__(self, path, name="sphrom", logging=False, token=None, messages=None):
        import time

        from fmpy import read_model_description
        path = Path(path)
        if not path.is_dir():
            check_archive(path)
        self.md = read_model_description(str(path))
        self._owns_dir = not path.is_dir()
        self.step_seconds = 0.0          # the CPU time inside the doStep calls of the last simulate() [s]
        self.first_step_seconds = 0.0    # ... inside its first doStep (a linear model's maps of a new step length) [s]
        self.unzipdir = str(path) if path.is_dir() else extract_fmu(path)
        self.fmi = 2 if self.md.fmiVersion == "2.0" else 3
        self.messages = [] if messages is None else messages
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.inputs = [v.name for v in self.md.modelVariables if v.causality == "input"]
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output"]
        # the model's outputs (v_probe_j, rho_probe_j, v_port_j): every output but the certified error bounds
        self.model_outputs = [n for n in self.outputs if not n.endswith("_error_bound")]
        # fmpy before 0.3.23 (the newest that installs with numpy 1.26, the oldest pyproject.toml allows) keeps an FMI 3
        # instantiationToken in guid
        token = token or (self.md.guid if self.fmi == 2 else getattr(self.md, "instantiationToken", None)
                          or self.md.guid)
        t0 = time.perf_counter()
        self.fmu = None
        try:
            check_binary(path, self.unzipdir, self.fmi)
            self.fmu = load_fmu(self.fmi, self.unzipdir, token, name)
        except Exception as exc:
            if self._owns_dir:
                shutil.rmtree(self.unzipdir, ignore_errors=True)
            if getattr(exc, "field", None) == "fmu":
                raise
            # a library the loader refuses, or one without the FMI functions (another version's, another FMI's)
            raise _fmu_error(path, f"its binary cannot be loaded ({' '.join(str(exc).split())[:200]})") from None
        except BaseException:
            if self._owns_dir:
                shutil.rmtree(self.unzipdir, ignore_errors=True)
            raise
        if self.fmi == 2:
            from ctypes import byref

            from fmpy.fmi1 import calloc, free
            from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                                   fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = fmi2_logger(fmi2CallbackLoggerTYPE)
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            self._environment = _register(self)
            callbacks.componentEnvironment = self._environment
            try:
                from fmpy.logging import addLoggerProxy
                addLoggerProxy(byref(callbacks))
            except Exception:       # pragma: no cover - proxy is optional
                pass
            self._callbacks = callbacks
            self._instantiate(lambda: self.fmu.instantiate(callbacks=callbacks, loggingOn=logging))
        else:
            self._instantiate(lambda: self.fmu.instantiate(loggingOn=logging, logMessage=self._log3))
        self.instantiate_s = time.perf_counter() - t0

    def _instantiate(self, call):
        """Run the instantiate call; on failure remove the folder we extracted, then raise
        :class:`InstantiateError` with the FMU's logged reasons (fmpy says only "Failed to instantiate model")."""
        try:
            call()
        except Exception as exc:
            self.fmu = None
            _INSTANCES.pop(getattr(self, "_environment", None), None)
            if self._owns_dir:
                shutil.rmtree(self.unzipdir, ignore_errors=True)
            if type(exc) is Exception and "instantiate" in str(exc).lower():
                raise InstantiateError([text for status, _, text in self.messages if status >= 3], exc) from None
            raise

    # -- what the FMU declares ------------------------------------------------
    @property
    def can_interpolate_inputs(self) -> bool:
        """Whether this FMU takes input derivatives (:func:`can_interpolate_inputs`)."""
        return can_interpolate_inputs(self.md)

    def has(self, name) -> bool:
        """Whether the FMU declares the variable ``name``."""
        return name in self.vr

    # -- logging ---------------------------------------------------------------
    def _keep(self, status, category, message):
        text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
        cat = category.decode() if isinstance(category, bytes) else str(category)
        self.messages.append((int(status), cat, text))

    def _log3(self, environment, status, category, message):
        self._keep(status, category, message)

    def errors(self):
        """Texts of the error messages logged so far."""
        return [text for status, _, text in self.messages if status >= 3]

    def warnings(self):
        """Texts of the warnings logged so far (e.g. leaving the training envelope)."""
        return [text for status, _, text in self.messages if status == 1]

    # -- lifecycle -------------------------------------------------------------
    def initialize(self, start=0.0, parameters=None, inputs=None, **named):
        """Set up, set the parameters and inputs, enter and exit initialization mode.

        ``parameters`` (and keyword arguments, e.g. ``n_freeze=5``) map names to start values; a value None
        keeps the FMU's start value (``initial_state_scale``: 0, the component at rest; pass 1 for the scene's
        initial state, as the training run had it).  A parameter the FMU does not declare (``n_freeze`` and
        ``dt`` in a linear model) is a FieldError naming it.  ``inputs`` maps input names to their values at
        ``start`` [s]."""
        values = {**(parameters or {}), **named}
        inputs = {**(inputs or {}), **{n: values.pop(n) for n in list(values) if n in self.inputs}}
        inputs = {n: x for n, x in inputs.items() if x is not None}
        fmu = self.fmu
        if self.fmi == 2:
            fmu.setupExperiment(startTime=start)
        for name, value in values.items():
            if value is not None:
                self.set_parameter(name, value)
        if self.fmi == 2:
            fmu.enterInitializationMode()
        else:
            fmu.enterInitializationMode(startTime=start)
        if inputs:
            self.set_real([self.vr[n] for n in inputs], list(inputs.values()))
        fmu.exitInitializationMode()
        return self

    def set_parameter(self, name, value):
        """Set the parameter ``name`` (its type from the variable table); FieldError when the FMU has none."""
        if name not in self.vr:
            raise absent(name)
        if lookup(name)[0].type == "Int32":
            (self.fmu.setInteger if self.fmi == 2 else self.fmu.setInt32)([self.vr[name]], [int(value)])
        else:
            self.set_real([self.vr[name]], [float(value)])

    def set_real(self, vrs, values):
        if self.fmi == 2:
            self.fmu.setReal(list(vrs), [float(v) for v in values])
        else:
            self.fmu.setFloat64(list(vrs), [float(v) for v in values])

    def get_real(self, vrs):
        if self.fmi == 2:
            return np.array(self.fmu.getReal(list(vrs)))
        return np.array(self.fmu.getFloat64(list(vrs)))

    def set_input(self, f):
        """The input f [m s^-2], held over the next communication step."""
        self.set_real([vr("f")], [float(f)])

    def set_input_derivatives(self, names, rates, order=1):
        """fmi2SetRealInputDerivatives: d^order u/dt^order of the inputs ``names`` over the next steps (FMI 2)."""
        if self.fmi != 2:
            raise ValueError("FMI 3.0 co-simulation has no input derivatives (the FMU holds its inputs)")
        n = len(names)
        self.fmu.fmi2SetRealInputDerivatives(self.fmu.component, _vrs([self.vr[x] for x in names]), n,
                                             (ctypes.c_int * n)(*([int(order)] * n)),
                                             (ctypes.c_double * n)(*[float(r) for r in rates]))

    def set_input_derivative(self, rate, order=1):
        """df/dt [m s^-3] of the input f over the next steps (FMI 2)."""
        self.set_input_derivatives(["f"], [rate], order)

    def output_derivatives(self, order=1, names=None):
        """d^order y/dt^order of the outputs ``names`` (default the model's outputs, :attr:`model_outputs`; the
        error bounds have none) at the FMU's time: fmi2GetRealOutputDerivatives / fmi3GetOutputDerivatives."""
        vrs = [self.vr[n] for n in (self.model_outputs if names is None else names)]
        orders = [int(order)] * len(vrs)
        if self.fmi == 2:
            return np.array(self.fmu.getRealOutputDerivatives(vrs, orders))
        return np.array(self.fmu.getOutputDerivatives(vrs, orders))

    def do_step(self, t, h):
        """fmi2DoStep / fmi3DoStep from ``t`` over ``h`` [s]."""
        if self.fmi == 2:
            self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        else:
            self.fmu.doStep(t, h)

    def output_values(self, names=None):
        """The outputs ``names`` (default the model's outputs, :attr:`model_outputs`, in their order)."""
        return self.get_real([self.vr[n] for n in (self.model_outputs if names is None else names)])

    def time(self):
        """The FMU's time [s]: FMI 3 ``time``, FMI 2 the last successful time."""
        if self.fmi == 3:
            return float(self.get_real([vr("time")])[0])
        from fmpy.fmi2 import fmi2LastSuccessfulTime
        return float(self.fmu.getRealStatus(fmi2LastSuccessfulTime))

    # -- the loop --------------------------------------------------------------
    def simulate(self, times, inputs=None, rates=False, outputs=None, feedback=None, on_step=None, steps=None,
                 stop_on_error=False):
        """Step the FMU over the communication points ``times`` and read outputs at every one of them.

        Parameters
        ----------
        times : array (M+1,)
            Communication points [s]; the FMU is initialized at ``times[0]``.
        inputs : dict, optional
            {input name: values (M+1,) at the communication points}; set before each step (the last value is
            only used for the slope of the last step).
        rates : bool or collection of str
            Hold the inputs over each step (False), or pass every input's slope to the next point as its
            derivative (True), or only those of the names given: the FMU then sees each such input linear over
            the step.  Needs :attr:`can_interpolate_inputs`.
        outputs : list of str, optional
            The outputs to read (default all, order of ``outputs``).
        feedback : callable, optional
            ``feedback(j, t_j, y_j) -> {input name: value}``: inputs computed from the outputs just read (a
            closed loop), set after ``inputs`` (held over the step).
        on_step : callable, optional
            ``on_step(j, t_j)`` after the outputs at point j are read (e.g. to read a state); may return
            True to stop (the result then ends at point j).
        steps : array (M,), optional
            The communication step lengths passed to doStep [s] (default ``diff(times)``; given, e.g., when
            the points were accumulated from them).
        stop_on_error : bool
            A call that returns an error status ends the loop and the points read so far are returned (the
            FMU's reason in :meth:`errors`) instead of raising fmpy's ``FMICallException``.

        Returns
        -------
        ndarray (M+1, len(outputs))
            The outputs at every communication point, the initial one included.  :attr:`step_seconds` is then
            the CPU time of this thread inside the doStep calls [s] (:func:`time.thread_time`: the FMU's own
            work, without this loop's, nor the time other processes took the core), :attr:`first_step_seconds`
            that of the first call alone (where a linear model computes the maps of a new step length, once).
        """
        times = np.asarray(times, dtype=float)
        inputs = {k: np.asarray(v, dtype=float) for k, v in (inputs or {}).items()}
        names = list(self.outputs if outputs is None else outputs)
        interpolate = list(inputs) if rates is True else [n for n in inputs if rates and n in rates]
        if interpolate and not self.can_interpolate_inputs:
            raise ValueError(f"this FMU (FMI {self.fmi}) takes no input derivatives: hold its inputs")
        fmu, comp = self.fmu, self.fmu.component
        out_vr, n_out = _vrs([self.vr[n] for n in names]), len(names)
        out = (ctypes.c_double * n_out)()
        in_names = list(inputs)
        in_vr, n_in = _vrs([self.vr[n] for n in in_names]), len(in_names)
        in_val = (ctypes.c_double * max(n_in, 1))()
        in_values = np.column_stack([inputs[n] for n in in_names]) if n_in else None
        d_vr = _vrs([self.vr[n] for n in interpolate])
        d_order = (ctypes.c_int * max(len(interpolate), 1))(*([1] * len(interpolate)))
        d_val = (ctypes.c_double * max(len(interpolate), 1))()
        cols = [in_names.index(n) for n in interpolate]
        fb_vr, fb_val = {}, (ctypes.c_double * 1)()
        if self.fmi == 2:
            get, set_ = fmu.fmi2GetReal, fmu.fmi2SetReal

            def step(t, h):
                fmu.fmi2DoStep(comp, t, h, 1)
        else:
            get, set_ = (lambda c, v, n, x: fmu.fmi3GetFloat64(c, v, n, x, n),
                         lambda c, v, n, x: fmu.fmi3SetFloat64(c, v, n, x, n))
            flags = [ctypes.c_bool() for _ in range(3)]
            last = ctypes.c_double()
            refs = [ctypes.byref(x) for x in flags] + [ctypes.byref(last)]

            def step(t, h):
                fmu.fmi3DoStep(comp, t, h, True, *refs)
        m = times.size - 1
        hs = np.diff(times) if steps is None else np.asarray(steps, dtype=float)
        ys = np.empty((m + 1, n_out))
        get(comp, out_vr, n_out, out)
        ys[0] = out
        reached = 0
        from fmpy.fmi1 import FMICallException
        from time import thread_time as perf   # CPU time of this thread: not the time other processes took the core
        stepping = self.first_step_seconds = 0.0
        try:
            for j in range(m):
                t, h = times[j], hs[j]
                if n_in:
                    in_val[:n_in] = in_values[j]
                    set_(comp, in_vr, n_in, in_val)
                if cols:
                    d_val[:len(cols)] = (in_values[j + 1, cols] - in_values[j, cols]) / h
                    fmu.fmi2SetRealInputDerivatives(comp, d_vr, len(cols), d_order, d_val)
                if feedback is not None:
                    for name, value in feedback(j, t, ys[j]).items():
                        if name not in fb_vr:
                            fb_vr[name] = _vrs([self.vr[name]])
                        fb_val[0] = value
                        set_(comp, fb_vr[name], 1, fb_val)
                c0 = perf()
                step(t, h)
                spent = perf() - c0
                stepping += spent
                if j == 0:
                    self.first_step_seconds = spent
                get(comp, out_vr, n_out, out)
                ys[j + 1] = out
                reached = j + 1
                if on_step is not None and on_step(j + 1, times[j + 1]):
                    break
        except FMICallException:
            if not stop_on_error:
                raise
        finally:
            self.step_seconds = stepping        # the CPU time inside the doStep calls of this loop [s]
        return ys[:reached + 1]

    def run(self, steps, inputs, t0=0.0):
        """Communication steps of lengths ``steps`` [s] with the inputs f = ``inputs`` held; the model's outputs
        (:attr:`model_outputs`: v_probe_j, rho_probe_j, v_port_j, not their error bounds) at every point (incl.
        t0)."""
        steps = np.asarray(steps, dtype=float)
        times = np.empty(steps.size + 1)
        times[0] = t = t0
        for j, h in enumerate(steps):          # t + h, one step after the other
            t = t + h
            times[j + 1] = t
        f = np.append(np.asarray(inputs, dtype=float), 0.0)
        return self.simulate(times, {"f": f}, steps=steps, outputs=self.model_outputs)

    # -- FMU state -------------------------------------------------------------
    def get_state(self):
        return self.fmu.getFMUstate() if self.fmi == 2 else self.fmu.getFMUState()

    def set_state(self, state):
        return self.fmu.setFMUstate(state) if self.fmi == 2 else self.fmu.setFMUState(state)

    def free_state(self, state):
        return self.fmu.freeFMUstate(state) if self.fmi == 2 else self.fmu.freeFMUState(state)

    def serialize(self, state) -> bytes:
        return bytes(self.fmu.serializeFMUstate(state) if self.fmi == 2 else self.fmu.serializeFMUState(state))

    def deserialize(self, blob: bytes):
        return self.fmu.deSerializeFMUstate(blob) if self.fmi == 2 else self.fmu.deserializeFMUState(blob)

    def reduced_state(self, k):
        """The FMU's k reduced coordinates, from a serialized FMU state (the model is not disturbed)."""
        state = self.get_state()
        try:
            return state_coordinates(self.serialize(state), k)
        finally:
            self.free_state(state)

    def reset(self):
        self.fmu.reset()

    def terminate(self):
        self.fmu.terminate()

    def close(self):
        """Free the instance (and the extracted folder when we made it)."""
        if getattr(self, "fmu", None) is not None:
            try:
                self.fmu.freeInstance()
            finally:
                self.fmu = None
                _INSTANCES.pop(getattr(self, "_environment", None), None)
                if self._owns_dir:
                    shutil.rmtree(self.unzipdir, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def open_fmu(path, **options):
    """:class:`FMU` of ``path`` (a context manager: ``with open_fmu(path) as fmu: ...``)."""
    return FMU(path, **options)

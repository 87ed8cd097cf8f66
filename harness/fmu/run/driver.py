"""One instance of an sphrom FMU through fmpy's FMI 2.0 / 3.0 classes.

A uniform, explicit driver for scripts and tests that need more control than
``fmpy.simulate_fmu``: the input held over each communication step, the
time reached (FMI 3 ``time``; FMI 2 ``fmi2GetRealStatus(LastSuccessfulTime)``),
FMU states, and the FMU's log messages (kept in ``messages``).
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from ..variables import vr

# fmpy's FMU constructors chdir() into binaries/<platform> to load the library
# and chdir() back: the working directory is per process, so two threads that
# construct at once can leave the process in another instance's (later deleted)
# folder.  Every construction of an fmpy FMU object in sphrom goes through this.
FMPY_LOAD_LOCK = threading.Lock()
STATE_HEADER_SIZE = 112     # ROM_STATE_HEADER_SIZE of fmu_src/rom.h: magic, version, sizes, token, time, counters


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


class Slave:
    """An instantiated sphrom FMU.

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
    outputs : list of str
        Output names (v_probe_*, then rho_probe_*).
    messages : list of (status, category, text)
        What the FMU logged.

    Raises
    ------
    Exception
        fmpy's, when instantiation fails (the FMU's reason is in ``messages``).
    """

    def __init__(self, path, name="sphrom", logging=False, token=None, messages=None):
        from fmpy import extract, read_model_description
        path = Path(path)
        self.md = read_model_description(str(path))
        self.unzipdir = str(path) if path.is_dir() else extract(str(path))
        self._owns_dir = not path.is_dir()
        self.fmi = 2 if self.md.fmiVersion == "2.0" else 3
        self.messages = [] if messages is None else messages
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output"]
        self._out_vr = [self.vr[n] for n in self.outputs]
        token = token or (self.md.guid if self.fmi == 2 else self.md.instantiationToken)
        if self.fmi == 2:
            from ctypes import byref

            from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                                   fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
            from fmpy.fmi1 import calloc, free
            self.fmu = load_fmu(2, self.unzipdir, token, name)
            callbacks = fmi2CallbackFunctions()
            callbacks.logger = fmi2CallbackLoggerTYPE(self._log2)
            callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
            callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
            try:
                from fmpy.logging import addLoggerProxy
                addLoggerProxy(byref(callbacks))
            except Exception:       # pragma: no cover - proxy is optional
                pass
            self._callbacks = callbacks
            self._instantiate(lambda: self.fmu.instantiate(callbacks=callbacks, loggingOn=logging))
        else:
            self.fmu = load_fmu(3, self.unzipdir, token, name)
            self._instantiate(lambda: self.fmu.instantiate(loggingOn=logging, logMessage=self._log3))

    def _instantiate(self, call):
        """Run the instantiate call; on failure remove the folder we extracted before re-raising."""
        try:
            call()
        except Exception:
            self.fmu = None
            if self._owns_dir:
                import shutil
                shutil.rmtree(self.unzipdir, ignore_errors=True)
            raise

    # -- logging ---------------------------------------------------------------
    def _keep(self, status, category, message):
        text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
        cat = category.decode() if isinstance(category, bytes) else str(category)
        self.messages.append((int(status), cat, text))

    def _log2(self, component, instance_name, status, category, message):
        self._keep(status, category, message)

    def _log3(self, environment, status, category, message):
        self._keep(status, category, message)

    def errors(self):
        """Texts of the error messages logged so far."""
        return [text for status, _, text in self.messages if status >= 3]

    # -- lifecycle -------------------------------------------------------------
    def initialize(self, start=0.0, n_freeze=None, dt=None, f=None, initial_state_scale=None):
        """Set up, set parameters/input, enter and exit initialization mode.

        A parameter left None keeps the FMU's start value (``initial_state_scale``: 0, the component at
        rest; pass 1 for the scene's initial state, as the training run had it).  A parameter the FMU does
        not have (``n_freeze`` and ``dt`` in a linear model) is a FieldError naming it."""
        fmu = self.fmu
        if self.fmi == 2:
            fmu.setupExperiment(startTime=start)
            self._set_parameters(n_freeze, dt, initial_state_scale)
            fmu.enterInitializationMode()
        else:
            self._set_parameters(n_freeze, dt, initial_state_scale)
            fmu.enterInitializationMode(startTime=start)
        if f is not None:
            self.set_input(f)
        fmu.exitInitializationMode()
        return self

    def _set_parameters(self, n_freeze, dt, initial_state_scale=None):
        for name, value in (("initial_state_scale", initial_state_scale), ("n_freeze", n_freeze), ("dt", dt)):
            if value is not None:
                self.set_parameter(name, value)

    def set_parameter(self, name, value):
        """Set the parameter ``name`` (its type from the variable table); FieldError when the FMU has none."""
        from ..variables import BY_NAME, absent
        if name not in self.vr:
            raise absent(name)
        if BY_NAME[name].type == "Int32":
            (self.fmu.setInteger if self.fmi == 2 else self.fmu.setInt32)([self.vr[name]], [int(value)])
        else:
            self.set_real([self.vr[name]], [float(value)])

    def set_real(self, vrs, values):
        if self.fmi == 2:
            self.fmu.setReal(list(vrs), list(values))
        else:
            self.fmu.setFloat64(list(vrs), list(values))

    def get_real(self, vrs):
        if self.fmi == 2:
            return np.array(self.fmu.getReal(list(vrs)))
        return np.array(self.fmu.getFloat64(list(vrs)))

    def set_input(self, f):
        """The input f [m s^-2], held over the next communication step."""
        self.set_real([vr("f")], [float(f)])

    def set_input_derivative(self, rate, order=1):
        """fmi2SetRealInputDerivatives on f: df/dt [m s^-3] over the next steps (FMI 2 only)."""
        from ctypes import c_double, c_int, c_uint32
        self.fmu.fmi2SetRealInputDerivatives(self.fmu.component, (c_uint32 * 1)(vr("f")), 1, (c_int * 1)(int(order)),
                                             (c_double * 1)(float(rate)))

    def output_derivatives(self, order=1, names=None):
        """d^order y/dt^order of the outputs ``names`` (default all, order of ``outputs``) at the FMU's time:
        fmi2GetRealOutputDerivatives / fmi3GetOutputDerivatives."""
        vrs = self._out_vr if names is None else [self.vr[n] for n in names]
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

    def output_values(self):
        """All outputs (order of ``outputs``)."""
        return self.get_real(self._out_vr)

    def time(self):
        """The FMU's time [s]: FMI 3 ``time``, FMI 2 the last successful time."""
        if self.fmi == 3:
            return float(self.get_real([vr("time")])[0])
        from fmpy.fmi2 import fmi2LastSuccessfulTime
        return float(self.fmu.getRealStatus(fmi2LastSuccessfulTime))

    def run(self, steps, inputs, t0=0.0):
        """Communication steps ``steps`` [s] with ``inputs`` held; outputs at every point (incl. t0)."""
        out = [self.output_values()]
        t = t0
        for h, f in zip(steps, inputs):
            self.set_input(f)
            self.do_step(t, h)
            t = t + h
            out.append(self.output_values())
        return np.array(out)

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
                if self._owns_dir:
                    import shutil
                    shutil.rmtree(self.unzipdir, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

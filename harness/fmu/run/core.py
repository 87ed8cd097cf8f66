"""ctypes access to the C model core (``libsphrom_core``, fmu_src/rom.h).

Used by the benchmark (ns per internal step without any FMI or Python in the
loop) and by tests that exercise the core directly.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np

from .sph_c import SphC

MESSAGE_SIZE = 1024         # ROM_MESSAGE_SIZE of fmu_src/rom.h: the core's message buffers


class _Section(ctypes.Structure):
    """fmu_src/rom.h RomSection."""
    _fields_ = [("tag", ctypes.c_char * 9), ("rows", ctypes.c_uint32), ("cols", ctypes.c_uint32),
                ("data", ctypes.POINTER(ctypes.c_double))]


class CoreError(RuntimeError):
    """A rom_* call failed; the message is the core's."""


class Core:
    """The loaded core library.

    Parameters
    ----------
    path : Path
        libsphrom_core (see :class:`sphrom.fmu.make.build.Binaries`).
    """

    def __init__(self, path):
        self.path = Path(path)
        lib = ctypes.CDLL(str(self.path))
        vp, sz, cp = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_char_p
        lib.rom_model_load_memory.argtypes = [ctypes.c_char_p, sz, ctypes.POINTER(vp), cp, sz]
        lib.rom_model_load_memory.restype = ctypes.c_int
        lib.rom_model_free.argtypes = [vp]
        lib.rom_model_free.restype = None
        lib.rom_state_new.argtypes = [vp]
        lib.rom_state_new.restype = vp
        lib.rom_state_free.argtypes = [vp]
        lib.rom_state_free.restype = None
        lib.rom_state_reset.argtypes = [vp, ctypes.c_double]
        lib.rom_state_reset.restype = None
        lib.rom_advance.argtypes = [vp, ctypes.c_int64, cp, sz]
        lib.rom_advance.restype = ctypes.c_int
        lib.rom_do_step.argtypes = [vp, ctypes.c_double, ctypes.c_double, cp, sz]
        lib.rom_do_step.restype = ctypes.c_int
        lib.rom_set_input.argtypes = [vp, ctypes.c_double, cp, sz]
        lib.rom_set_input.restype = ctypes.c_int
        lib.rom_set_n_freeze.argtypes = [vp, ctypes.c_int64, cp, sz]
        lib.rom_set_n_freeze.restype = ctypes.c_int
        lib.rom_v_probe.argtypes = [vp, ctypes.c_uint32]
        lib.rom_v_probe.restype = ctypes.c_double
        lib.rom_rho_probe.argtypes = [vp, ctypes.c_uint32]
        lib.rom_rho_probe.restype = ctypes.c_double
        lib.rom_crc32.argtypes = [ctypes.c_char_p, sz]
        lib.rom_crc32.restype = ctypes.c_uint32
        lib.rom_set_input_rate.argtypes = [vp, ctypes.c_double, cp, sz]
        lib.rom_set_input_rate.restype = ctypes.c_int
        lib.rom_reduced_state.argtypes = [vp, ctypes.POINTER(ctypes.c_double), sz]
        lib.rom_reduced_state.restype = sz
        lib.rom_expm_count.argtypes = [vp]
        lib.rom_expm_count.restype = ctypes.c_int64
        lib.rom_model_kind.argtypes = [vp]
        lib.rom_model_kind.restype = ctypes.c_uint32
        lib.rom_model_section.argtypes = [vp, cp]
        lib.rom_model_section.restype = ctypes.POINTER(_Section)
        lib.rom_max_steps_per_call.argtypes = [vp]
        lib.rom_max_steps_per_call.restype = ctypes.c_double
        lib.rom_step_work.argtypes = [vp]
        lib.rom_step_work.restype = ctypes.c_double
        lib.rom_frozen_refresh.argtypes = [vp, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int)]
        lib.rom_frozen_refresh.restype = ctypes.c_int
        lib.rom_frozen_set_refresh.argtypes = [vp, ctypes.c_int, ctypes.c_int, cp, sz]
        lib.rom_frozen_set_refresh.restype = ctypes.c_int
        lib.rom_set_initial_state_scale.argtypes = [vp, ctypes.c_double, cp, sz]
        lib.rom_set_initial_state_scale.restype = ctypes.c_int
        lib.rom_set_dt.argtypes = [vp, ctypes.c_double, cp, sz]
        lib.rom_set_dt.restype = ctypes.c_int
        lib.rom_envelope_check.argtypes = [vp, cp, sz]
        lib.rom_envelope_check.restype = ctypes.c_int
        # mechanical ports and the port channel (rom.h)
        u32, d = ctypes.c_uint32, ctypes.c_double
        for name, args, res in (("rom_n_ports", [vp], u32), ("rom_set_port_force", [vp, u32, d, cp, sz], ctypes.c_int),
                                ("rom_v_port", [vp, u32], d), ("rom_set_area", [vp, d, cp, sz], ctypes.c_int),
                                ("rom_set_port_impedance", [vp, d, cp, sz], ctypes.c_int),
                                ("rom_set_port_wave", [vp, u32, d, cp, sz], ctypes.c_int),
                                ("rom_port_reflected", [vp, u32], d), ("rom_channel_energy", [vp], d),
                                ("rom_v_probe_error_bound", [vp, u32], d), ("rom_v_port_error_bound", [vp, u32], d)):
            getattr(lib, name).argtypes = args
            getattr(lib, name).restype = res
        self.lib = lib
        self._sph = None

    @property
    def sph(self):
        """The C full SPH (:class:`sphrom.fmu.run.sph_c.SphC`) of the same build: libsphrom_sph beside this library."""
        if self._sph is None:
            self._sph = SphC(self.path.with_name(self.path.name.replace("sphrom_core", "sphrom_sph")))
        return self._sph

    def load(self, blob: bytes) -> "CoreModel":
        """A model from model.bin bytes; CoreError with the loader's message on failure."""
        handle = ctypes.c_void_p()
        msg = ctypes.create_string_buffer(MESSAGE_SIZE)
        if self.lib.rom_model_load_memory(blob, len(blob), ctypes.byref(handle), msg, MESSAGE_SIZE) != 0:
            raise CoreError(msg.value.decode())
        return CoreModel(self, handle)


def built_core() -> Core:
    """The C core of this machine's binaries, built or found in the cache
    (:func:`sphrom.fmu.make.build.ensure_binaries`)."""
    from ..make.build import ensure_binaries
    return Core(ensure_binaries(quiet=True).core)


class CoreModel:
    """A loaded model and one state on it (freed on close / garbage collection)."""

    def __init__(self, core, handle):
        self.core = core
        self.model = handle
        self.state = ctypes.c_void_p(core.lib.rom_state_new(handle))
        self._msg = ctypes.create_string_buffer(MESSAGE_SIZE)

    def _check(self, status):
        if status != 0:
            raise CoreError(self._msg.value.decode())

    def reset(self, t_start=0.0):
        self.core.lib.rom_state_reset(self.state, t_start)

    def section(self, tag):
        """The tagged section ``tag`` as the core read it: a (rows, cols) array, or None when absent."""
        import numpy as np
        ptr = self.core.lib.rom_model_section(self.model, tag.encode("ascii"))
        if not ptr:
            return None
        s = ptr.contents
        n = s.rows * s.cols
        return np.ctypeslib.as_array(s.data, shape=(n,)).copy().reshape(s.rows, s.cols) if n else np.zeros((0, 0))

    def envelope_check(self):
        """The core's envelope message for the current state and input (None inside the envelope)."""
        return self._msg.value.decode() if self.core.lib.rom_envelope_check(self.state, self._msg,
                                                                            MESSAGE_SIZE) else None

    def set_n_freeze(self, n_freeze):
        self._check(self.core.lib.rom_set_n_freeze(self.state, n_freeze, self._msg, MESSAGE_SIZE))

    def set_dt(self, dt):
        self._check(self.core.lib.rom_set_dt(self.state, dt, self._msg, MESSAGE_SIZE))

    def max_steps_per_call(self):
        """The most internal steps one doStep takes at the state's settings (fmu_src/rom.h)."""
        return self.core.lib.rom_max_steps_per_call(self.state)

    def step_work(self):
        """Multiply-adds of one internal step at the state's settings (fmu_src/rom.h rom_step_work)."""
        return self.core.lib.rom_step_work(self.state)

    def set_input(self, f):
        self._check(self.core.lib.rom_set_input(self.state, f, self._msg, MESSAGE_SIZE))

    def set_input_rate(self, rate):
        """Exact model: the input goes linearly over each step with this df/dt (0 holds it)."""
        self._check(self.core.lib.rom_set_input_rate(self.state, rate, self._msg, MESSAGE_SIZE))

    def reduced_state(self):
        """(a^v, a^rho) (frozen) or (a, b) (exact) as one array."""
        import numpy as np
        out = np.zeros(2 * 1024)
        n = self.core.lib.rom_reduced_state(self.state, out.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                                            out.size)
        return out[:n].copy()

    @property
    def expm_count(self):
        """Matrix exponentials computed so far (exact model)."""
        return int(self.core.lib.rom_expm_count(self.state))

    @property
    def kind(self):
        return int(self.core.lib.rom_model_kind(self.model))

    @property
    def refresh(self):
        """The frozen model's refresh (fmu_src/rom.h rom_frozen_refresh): ``path`` "tensor" or "symmetric" (the
        tensor stored by its symmetry, the same bits; chosen at load by measured cost) or "particles" (sections
        PART*, decided at packaging: other bits, the Python model's ``refresh="direct"``), ``skip`` whether a
        refresh of unchanged inputs is skipped (the same bits)."""
        path, skip = ctypes.c_int(), ctypes.c_int()
        if self.core.lib.rom_frozen_refresh(self.model, ctypes.byref(path), ctypes.byref(skip)) != 0:
            raise CoreError("the refresh: not a frozen-coefficient model")
        return {"path": ("tensor", "symmetric", "particles")[path.value], "skip": bool(skip.value)}

    def set_refresh(self, path=None, skip=None):
        """Force the frozen model's refresh path ("tensor", "symmetric", "particles") and/or its skip (tests,
        benchmarks)."""
        code = -1 if path is None else {"tensor": 0, "symmetric": 1, "particles": 2}[path]
        self._check(self.core.lib.rom_frozen_set_refresh(self.model, code, -1 if skip is None else int(bool(skip)),
                                                         self._msg, MESSAGE_SIZE))

    def set_initial_state_scale(self, scale):
        """initial_state_scale (0: start at rest), before the first step (a reset sets it back to 1)."""
        self._check(self.core.lib.rom_set_initial_state_scale(self.state, float(scale), self._msg, MESSAGE_SIZE))

    def advance(self, n_steps):
        """n_steps whole internal steps (with the runaway check)."""
        self._check(self.core.lib.rom_advance(self.state, int(n_steps), self._msg, MESSAGE_SIZE))

    def do_step(self, t, h):
        self._check(self.core.lib.rom_do_step(self.state, t, h, self._msg, MESSAGE_SIZE))

    def outputs(self, n_probes):
        lib = self.core.lib
        return ([lib.rom_v_probe(self.state, j) for j in range(n_probes)],
                [lib.rom_rho_probe(self.state, j) for j in range(n_probes)])

    @property
    def n_ports(self):
        return int(self.core.lib.rom_n_ports(self.model))

    def set_port_forces(self, forces):
        """F_port_j [N], held over the next steps."""
        for j, F in enumerate(forces):
            self._check(self.core.lib.rom_set_port_force(self.state, j, float(F), self._msg, MESSAGE_SIZE))

    def port_velocities(self):
        """v_port_j [m s^-1]."""
        return np.array([self.core.lib.rom_v_port(self.state, j) for j in range(self.n_ports)])

    def error_bounds(self, n_probes):
        """The certified error bounds of v_probe_j then v_port_j [m s^-1] (NaN: the model has none)."""
        lib = self.core.lib
        return np.array([lib.rom_v_probe_error_bound(self.state, j) for j in range(n_probes)] +
                        [lib.rom_v_port_error_bound(self.state, j) for j in range(self.n_ports)])

    def set_port_impedance(self, impedance):
        """The wave form's port_impedance Z [N s m^-1] (0: the force form)."""
        self._check(self.core.lib.rom_set_port_impedance(self.state, float(impedance), self._msg, MESSAGE_SIZE))

    def set_port_waves(self, waves):
        """The incident waves a_port_j [N] of the wave form."""
        for j, a in enumerate(waves):
            self._check(self.core.lib.rom_set_port_wave(self.state, j, float(a), self._msg, MESSAGE_SIZE))

    def reflected_waves(self):
        """b_port_j [N] after the last step (the wave form)."""
        return np.array([self.core.lib.rom_port_reflected(self.state, j) for j in range(self.n_ports)])

    def channel_energy(self):
        """The port channel's energy ½ |w|² Δx area [J] (0 without it)."""
        return float(self.core.lib.rom_channel_energy(self.state))

    def close(self):
        if self.state:
            self.core.lib.rom_state_free(self.state)
            self.state = None
        if self.model:
            self.core.lib.rom_model_free(self.model)
            self.model = None

    def __del__(self):
        try:
            self.close()
        except Exception:       # interpreter shutdown
            pass

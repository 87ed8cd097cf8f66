"""ctypes access to the full SPH step in C (fmu_src/sph.c, library ``libsphrom_sph``).

The C step repeats :mod:`sphrom.sph.loops` (eqs. 2.10-2.11 with the
neighbour lists of :mod:`sphrom.sph.operator`, or their fixed-offset stencil)
operation for operation, bit for bit (tests/test_fmu_c.py,
tests/test_sph_stencil.py).  It exists for the same-language benchmark: a C
frozen reduced step against a C full SPH step (``sphrom bench``,
``sphrom bench-fmu``).  It is a library of its own, beside the model core's.
"""

from __future__ import annotations

import ctypes
import time
from pathlib import Path

import numpy as np

METHODS = {"euler": 0, "symplectic": 1}
MESSAGE_SIZE = 1024        # bytes of the buffer that receives the C side's message (its size is passed along)


class SphError(RuntimeError):
    """An sph_* call failed (non-finite state, rho <= 0, bad arguments); the message is the C side's."""


class SphC:
    """The loaded C full SPH library.

    Parameters
    ----------
    path : Path
        libsphrom_sph (see :class:`sphrom.fmu.make.build.Binaries`).
    """

    def __init__(self, path):
        self.path = Path(path)
        lib = ctypes.CDLL(str(self.path))
        p = ctypes.c_void_p
        lib.sph_advance_flat.argtypes = [ctypes.c_int64, ctypes.c_int64, p, p, p, p, p, p, ctypes.c_uint32,
                                         ctypes.c_int, p, p, ctypes.c_int64, ctypes.c_double, p, p, ctypes.c_int64,
                                         ctypes.POINTER(ctypes.c_int64), ctypes.c_char_p, ctypes.c_size_t]
        lib.sph_advance_flat.restype = ctypes.c_int
        self.lib = lib

    def runner(self, problem, method="euler", layout="auto"):
        return SphRunner(self, problem, method, layout)


class SphRunner:
    """One problem's arrays held for repeated C calls.

    Parameters
    ----------
    problem : SPHProblem
    method : {"euler", "symplectic"}
    layout : {"auto", "general"}
        The operator's layout (:meth:`sphrom.sph.operator.Neighbours.loop_arrays`): "auto" the fixed-offset
        stencil where the neighbour lists allow it (flag SPH_STENCIL), "general" the lists; the same bits.
    """

    def __init__(self, sph, problem, method="euler", layout="auto"):
        if method not in METHODS:
            raise ValueError(f"method {method!r} (allowed: euler, symplectic)")
        self.sph, self.problem, self.method = sph, problem, METHODS[method]
        index, weight, self.layout_bit = problem.neighbours.loop_arrays(layout)
        self.index = np.ascontiguousarray(index, dtype=np.int64)
        self.weight = np.ascontiguousarray(weight, dtype=float)
        self.k = problem.neighbours.index.shape[1]
        self.fields = [np.ascontiguousarray(problem.packed(name), dtype=float)
                       for name in ("rho0", "c", "d", "profile")]
        self.work = np.empty(3 * problem.n)
        self._msg = ctypes.create_string_buffer(MESSAGE_SIZE)

    def advance(self, v, rho, n_steps, dt, g=None, check_every=64):
        """Advance (v, rho) in place by n_steps steps of dt; g: f per step (None: no force).

        Returns the wall time [s] of the C call; SphError on a failure (non-finite, rho <= 0).
        """
        n = self.problem.n
        if v.dtype != float or rho.dtype != float or not (v.flags.c_contiguous and rho.flags.c_contiguous):
            raise ValueError("v, rho must be contiguous float64 arrays")
        gs = None if g is None else np.ascontiguousarray(g, dtype=float)
        if gs is not None and gs.size < n_steps:
            raise ValueError("g needs one value per step")
        flags = self.problem.flags(gs is not None and bool(np.any(gs != 0))) | self.layout_bit
        done = ctypes.c_int64(0)
        ptr = lambda a: None if a is None else a.ctypes.data      # noqa: E731
        t0 = time.perf_counter()
        status = self.sph.lib.sph_advance_flat(n, self.k, ptr(self.index), ptr(self.weight),
                                               *[ptr(a) for a in self.fields], flags, self.method, ptr(v), ptr(rho),
                                               int(n_steps), float(dt), ptr(gs), ptr(self.work), int(check_every),
                                               ctypes.byref(done), self._msg, MESSAGE_SIZE)
        wall = time.perf_counter() - t0
        if status != 0:
            raise SphError(self._msg.value.decode())
        return wall

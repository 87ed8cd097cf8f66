"""The FMU's co-simulation in Python, the reference its outputs must equal: each model kind's own, gathered here.

The frozen model's (:func:`cosim_reference`, :class:`FrozenCosim` and doStep's rules: :func:`split_step`, the work
bound) is :mod:`sphrom.fmu.kinds.frozen`'s; the linear models' output rates (:func:`linear_output_rates`) are
:mod:`sphrom.fmu.kinds.linear`'s (their outputs are the Python models' own runs, exact in time).  This module keeps
the names the checks and tests have always imported.
"""

from __future__ import annotations

from ..kinds.frozen import (DT_FLOOR_RATIO, DT_MIN, MAX_WORK_PER_CALL, SHORT_STEP_MIN, STEP_OVERHEAD,  # noqa: F401
                            STEP_ROUNDING, FrozenCosim, cosim_reference, dt_floor, max_steps_per_call, probe_values,
                            refresh_matrix_work, split_step, step_work)
from ..kinds.linear import linear_output_rates  # noqa: F401

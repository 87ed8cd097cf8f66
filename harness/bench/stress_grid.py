"""The grid of the stress maps: Δt factors, amplitudes, horizons and mode counts.

A leaf module (numbers only), so that the command line, :mod:`.stress` (the
runs) and :mod:`.stress_maps` (the study over several scenes) share the grid
without importing each other.
"""

DEFAULT_SCENES = ("tenmode", "damped_forced", "heterogeneous")
DT_FACTORS = (0.1, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0)    # Δt / Δt*
AMPLITUDES = (1, 10, 100, 1000)           # initial-amplitude factors
HORIZONS = (10.0, 100.0, 1000.0)          # T [s] at the paper's Δt
MODE_COUNTS = (4, 8, 12, 20, 40, 100)     # the k sweep (capped at the snapshot count)
QUICK_DT_FACTORS = (0.5, 1.0, 2.0)

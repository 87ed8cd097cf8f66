"""The stress maps' grid and scene list (``sphrom stress``): plain constants, imported by the command's parser,
:mod:`sphrom.bench.lib.stress` and :mod:`sphrom.bench.lib.stress_maps` (a leaf: it imports nothing of sphrom)."""

DEFAULT_SCENES = ("tenmode", "damped_forced", "heterogeneous")
DT_FACTORS = (0.1, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0)    # Δt / Δt*
AMPLITUDES = (1, 10, 100, 1000)           # initial-amplitude factors
HORIZONS = (10.0, 100.0, 1000.0)          # T [s] at the paper's Δt
MODE_COUNTS = (4, 8, 12, 20, 40, 100)     # the k sweep (capped at the snapshot count)
QUICK_DT_FACTORS = (0.5, 1.0, 2.0)
HORIZON_METHODS = ("sph-euler", "sph-symplectic", "frozen", "exact")     # every horizon
SHORT_HORIZON_METHODS = ("sph-rk4", "original", "linearized")            # horizons up to SHORT_HORIZON only
SHORT_HORIZON = 100.0                                                    # [s]

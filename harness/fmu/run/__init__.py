"""Running an FMU from Python: :mod:`.driver` is the one driver (every loop that steps an FMU goes through it),
:mod:`.cosim` is ``sphrom cosim`` on it; :mod:`.core` and :mod:`.sph_c` reach the C libraries through ctypes
(the model core without FMI, the C full SPH step of the benchmark)."""

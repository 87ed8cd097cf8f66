"""Checking an FMU: :mod:`.verify` measures a packaged FMU against the full SPH (``sphrom fmu``'s verification);
:mod:`.python_cosim` is the Python mirror of the FMU's co-simulation that the C code must equal bit for bit."""

"""The FMU: a reduced model (frozen coefficients, exact linear or balanced) as FMI 2.0 / 3.0 co-simulation.

Public names (imported from their modules on first use)::

    package_fmu, FMUSummary      sphrom fmu: scene -> validated .fmu               (package)
    run_cosim, CosimResult       sphrom cosim: fmpy.simulate_fmu with a force      (cosim)
    Slave, load_fmu              one FMU instance through fmpy, with its log       (fmi)
    cosim_reference              the FMU's co-simulation in Python                 (python_cosim)
    ensure_binaries, Binaries    the binaries from fmu_src/, built once and cached (build)
    model_data, exact_data, balanced_data, pack, pack_exact, unpack, ModelData, ExactData
                                 resources/model.bin: frozen (kind 1), exact and balanced (kind 2) (resources)
    Core, CoreModel              ctypes access to the C core                       (core)

Modules: ``resources`` (model.bin: format and token), ``build`` (CMake),
``describe`` (modelDescription.xml from the templates in modelDescription/ and the variable table),
``package``, ``python_cosim`` (the equality reference of the C code),
``fmi``, ``cosim``, ``core``, ``sph_c`` (the C full SPH step, for the
benchmark), ``verify`` (the packaged FMU against the full SPH: errors and run
times), ``documentation`` (documentation/index.html), ``variables`` (the
one declaration of every FMU variable, and the files generated from it).  The FMU benchmark is
:mod:`harness.bench.fmu`; the verification for every scene is
:mod:`harness.bench.fmu_verify`.
"""

from ..lazy import lazy_exports

EXPORTS = {
    "package_fmu": "package", "FMUSummary": "package",
    "run_cosim": "cosim", "CosimResult": "cosim",
    "Slave": "fmi", "load_fmu": "fmi",
    "cosim_reference": "python_cosim",
    "ensure_binaries": "build", "Binaries": "build",
    "model_data": "resources", "exact_data": "resources", "balanced_data": "resources", "pack": "resources",
    "pack_exact": "resources", "unpack": "resources",
    "ModelData": "resources", "ExactData": "resources",
    "Core": "core", "CoreModel": "core",
}
__all__ = sorted(EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, EXPORTS)

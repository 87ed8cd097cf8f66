"""The FMU: a reduced model (frozen coefficients, exact linear or balanced) as FMI 2.0 / 3.0 co-simulation.

One job per folder::

    variables.py   the one declaration of every FMU variable, and the files generated from it (the contract)
    layout.py      the binary contract written once: model.bin's and the serialized state's layout, from which
                   fmu_src/rom_layout.h is generated (python3 -m sphrom.fmu.layout --write)
    kinds/         one module per model kind of model.bin (frozen, linear): its data, its part of the file, its
                   build options and packaging step, its words, its Python co-simulation (the C core's RomKindOps);
                   pack and unpack of any kind's model.bin
    training/      what packaging learns from the scene for every kind: the POD basis and training run, the
                   training envelope, the certified bounds' shadow
    resources.py   resources/model.bin's shared pieces: header, sections, token, crc (write, read); the kinds'
                   pack and unpack call them
    make/          making an FMU: option checks, per-kind resources, parametric models, modelDescription.xml,
                   documentation page, binaries (CMake), the archive, package_fmu's steps, --model auto, what
                   sphrom fmu asks for (request.py)
    run/           running an FMU: the one Python driver of an FMU (driver.py), sphrom cosim (cosim.py), the C
                   core and the C full SPH through ctypes (core.py, sph_c.py)
    check/         checking an FMU: measured against the full SPH (verify.py), the Python mirror of its
                   co-simulation that the C code must equal (python_cosim.py)

Public names (imported from their modules on first use)::

    package_fmu, FMUSummary      sphrom fmu: scene -> validated .fmu               (make.package)
    package_auto                 sphrom fmu --model auto                           (make.auto)
    run_cosim, CosimResult       sphrom cosim                                      (run.cosim)
    FMU, load_fmu                one FMU instance driven from Python; fmpy's instance of an unpacked FMU
                                                                                   (run.driver)
    cosim_reference              the FMU's co-simulation in Python                 (check.python_cosim)
    verify_fmu                   the FMU against the full SPH                      (check.verify)
    ensure_binaries, Binaries    the binaries from fmu_src/, built once and cached (make.build)
    pack, pack_exact, unpack     resources/model.bin of any kind's data, and back  (kinds; the shared header,
                                 sections, token and checksum: resources.write, resources.read)
    model_data, exact_data, balanced_data, ModelData, ExactData
                                 the data of kind 1 (frozen) and kind 2 (exact, balanced) (resources' old names;
                                 they are the kinds', kinds.frozen and kinds.linear)
    kind_of                      the model kind module of a model's data                  (kinds)
    Core, CoreModel              ctypes access to the C core                       (run.core)

The measurements that run FMUs are programs of :mod:`sphrom.bench` (``sphrom bench --list``).
"""

from ..lazy import lazy_exports

EXPORTS = {
    "package_fmu": "make.package", "FMUSummary": "make.package", "package_auto": "make.package",
    "run_cosim": "run.cosim", "CosimResult": "run.cosim",
    "FMU": "run.driver", "load_fmu": "run.driver",
    "cosim_reference": "check.python_cosim", "verify_fmu": "check.verify",
    "ensure_binaries": "make.build", "Binaries": "make.build",
    "model_data": "resources", "exact_data": "resources", "balanced_data": "resources", "pack": "kinds",
    "pack_exact": "kinds", "unpack": "kinds",
    "ModelData": "resources", "ExactData": "resources", "kind_of": "kinds",
    "Core": "run.core", "CoreModel": "run.core",
}
__all__ = sorted(EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, EXPORTS)

"""The public names of each package are importable from the package itself, and are the objects of their modules."""

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

PUBLIC = {
    "sphrom": ["load_scene", "package_fmu", "FMU", "run_cosim", "verify_fmu"],
    "sphrom.sph": ["build_problem", "run_sph", "SPHProblem", "SPHResult", "step_count", "stability",
                    "stability_warnings", "energy_bound_factors", "energy", "momentum", "total_length",
                    "cubic_spline", "cubic_spline_gradient", "build_neighbours", "Neighbours", "particle_positions"],
    "sphrom.pod": ["basis_for_scene", "pod", "weighted_pod", "build_basis", "Basis", "read_basis", "write_basis",
                    "snapshot_steps"],
    "sphrom.rom": ["get_model", "MODELS", "MODEL_NAMES", "ReducedModel", "ReducedResult", "build_operators",
                    "build_linear_operators", "Operators", "fmu_model_names"],
    "sphrom.references": ["exact_solution", "is_available", "check_available", "ExactUnavailable",
                           "best_reference", "Reference", "study"],
    "sphrom.fmu": ["package_fmu", "FMUSummary", "run_cosim", "CosimResult", "FMU", "load_fmu", "cosim_reference",
                    "ensure_binaries", "Binaries", "model_data", "exact_data", "pack", "unpack", "ModelData",
                    "ExactData", "kind_of", "Core", "CoreModel"],
}


@pytest.mark.parametrize("package", sorted(PUBLIC))
def test_public_names_import_from_their_package(package):
    mod = importlib.import_module(package)
    for name in PUBLIC[package]:
        value = getattr(mod, name)
        assert name in mod.__all__ and name in dir(mod), (package, name)
        assert name in mod.__doc__, f"{package}'s docstring does not list {name}"
        # the very object of the module that defines it (re-exported, not copied or wrapped)
        home = importlib.import_module(value.__module__) if hasattr(value, "__module__") else None
        if home is not None and home.__name__.startswith(package + "."):
            assert getattr(home, name) is value, (package, name)
    ns = {}
    exec(f"from {package} import {', '.join(PUBLIC[package])}", ns)
    assert all(n in ns for n in PUBLIC[package])
    with pytest.raises(AttributeError):
        getattr(mod, "no_such_name")


def test_the_solver_modules_import_from_the_references_package():
    from sphrom.references import fd, pypde_ref, skfem_ref
    assert all(callable(m.solve) for m in (fd, pypde_ref, skfem_ref))


def test_importing_a_package_stays_light():
    """The lazy re-exports import nothing heavy until a name is used: fmpy, numba, scikit-fem, py-pde stay out."""
    code = ("import sys, sphrom.sph, sphrom.references, sphrom.fmu; "
            "print(sorted(m for m in ('fmpy', 'numba', 'skfem', 'pde') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout

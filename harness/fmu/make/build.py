"""Build the FMU binaries from ``fmu_src/`` with CMake, once, and cache them.

The binaries do not depend on the scene (its numbers live in
``resources/model.bin``), so they are built once per source tree and fmpy
version and kept under ``$SPHROM_CACHE/build/<key>/`` (default
``~/.cache/sphrom/build``); packaging another scene needs no compiler.  The key
is a hash of every file in ``fmu_src/``, the fmpy version (its FMI headers),
the platform and the build flavour (release or sanitizer).  A build runs in a
temporary folder under a file lock and is renamed into place when complete,
so concurrent sessions never see half a build.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from ...errors import UserError
from ...paths import data_dir

BUILD_TYPE = "Release"

CMAKE_LISTS = "CMakeLists.txt"
_SET = re.compile(r"^set\((SPHROM_\w+_SOURCES)\s+([^)]*)\)", re.M)


def cmake_sources(root=None):
    """{list name: file names} of the ``set(SPHROM_..._SOURCES ...)`` commands of fmu_src/CMakeLists.txt, the one
    place that lists the C sources (SPHROM_CORE_SOURCES: the model core; SPHROM_INSTANCE_SOURCES: the FMU
    instance)."""
    text = (Path(root or data_dir("fmu_src")) / CMAKE_LISTS).read_text(encoding="utf-8")
    return {name: tuple(body.split()) for name, body in _SET.findall(text)}


def fmu_sources(fmi):
    """The fmu_src/ files of the FMI ``fmi`` FMU's sources/ folder: the model core and the instance layer (as
    CMakeLists.txt lists them) and the FMI adapter.  Their C files are the modelDescription's <SourceFiles> in
    FMI 2 and buildDescription.xml's in FMI 3 (:mod:`sphrom.fmu.make.describe`)."""
    lists = cmake_sources()
    return [*lists["SPHROM_CORE_SOURCES"], *lists["SPHROM_INSTANCE_SOURCES"], f"fmi{fmi}_cs.c"]


@dataclass(frozen=True)
class Binaries:
    """Paths of one build.

    Attributes
    ----------
    folder : Path
        The build folder (CMake's binary dir).
    fmi2, fmi3 : Path
        The FMI 2.0 and 3.0 co-simulation shared libraries.
    core : Path
        The core library with the rom_* functions exported (ctypes).
    sph : Path
        The C full SPH step with the sph_* functions exported (ctypes, benchmark).
    driver : Path or None
        The C test driver (tests/driver.c).
    sanitize : bool
        Built with -fsanitize=address,undefined.
    """

    folder: Path
    fmi2: Path
    fmi3: Path
    core: Path
    sph: Path
    driver: Path | None
    sanitize: bool


def fmi_headers_dir() -> Path:
    """fmpy's folder of FMI headers (``fmpy/c-code``)."""
    import fmpy
    return Path(fmpy.__file__).resolve().parent / "c-code"


def source_files():
    """Every file of ``fmu_src/`` (relative paths, sorted), build outputs excluded."""
    root = data_dir("fmu_src")
    files = []
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root)
        if path.is_file() and not any(part.startswith((".", "build")) or part == "__pycache__" for part in rel.parts):
            files.append(rel)
    return root, files


def build_key(sanitize=False):
    """Hash of the sources, the fmpy version, the platform and the flavour (16 hex digits)."""
    import fmpy
    root, files = source_files()
    digest = hashlib.sha256()
    for rel in files:
        digest.update(str(rel).encode() + b"\0" + (root / rel).read_bytes() + b"\0")
    digest.update(f"fmpy {fmpy.__version__}\n{sys.platform}\n{BUILD_TYPE}\nsanitize={bool(sanitize)}".encode())
    return digest.hexdigest()[:16]


def _library_name(stem):
    import fmpy
    return f"{stem}.{fmpy.sharedLibraryExtension.lstrip('.')}"


def _target_library(folder: Path, target):
    """The shared library CMake builds for ``target`` (lib<target>.so/.dylib, <target>.dll)."""
    return folder / (f"{target}.dll" if sys.platform == "win32" else _library_name(f"lib{target}"))


def _binaries(folder: Path, sanitize):
    driver = folder / ("sphrom_driver.exe" if sys.platform == "win32" else "sphrom_driver")
    return Binaries(folder=folder, fmi2=folder / "fmi2" / _library_name("sphrom"),
                    fmi3=folder / "fmi3" / _library_name("sphrom"), core=_target_library(folder, "sphrom_core"),
                    sph=_target_library(folder, "sphrom_sph"), driver=driver if driver.exists() else None,
                    sanitize=sanitize)


def _complete(b: Binaries):
    return all(p.is_file() for p in (b.fmi2, b.fmi3, b.core, b.sph, b.folder / "build.ok"))


@contextlib.contextmanager
def _locked(path: Path):
    """An exclusive lock on ``path`` (POSIX flock; no lock elsewhere)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+") as fh:
        try:
            import fcntl
        except ImportError:          # pragma: no cover - not POSIX
            yield
            return
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def cmake_command():
    cmake = shutil.which("cmake")
    if cmake is None:
        raise UserError("cannot build the FMU binary: cmake not found on PATH (install cmake >= 3.16 and a C compiler)")
    return cmake


def configure_and_build(source: Path, folder: Path, sanitize=False, tests=True, log=None):
    """Run CMake on ``source`` into ``folder`` (Release, -Wall -Wextra -Werror).

    Returns the combined output.  Raises UserError naming the log file when
    the configure or build step fails.
    """
    cmake = cmake_command()
    folder.mkdir(parents=True, exist_ok=True)
    configure = [cmake, "-S", str(source), "-B", str(folder), f"-DCMAKE_BUILD_TYPE={BUILD_TYPE}",
                 f"-DFMI_HEADERS_DIR={fmi_headers_dir()}", f"-DPython3_EXECUTABLE={sys.executable}",
                 f"-DSPHROM_SANITIZE={'ON' if sanitize else 'OFF'}", f"-DSPHROM_BUILD_TESTS={'ON' if tests else 'OFF'}"]
    build = [cmake, "--build", str(folder), "--config", BUILD_TYPE, "--parallel", str(min(4, os.cpu_count() or 1))]
    output = []
    for command in (configure, build):
        proc = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        output.append("$ " + " ".join(command) + "\n" + proc.stdout)
        if proc.returncode != 0:
            text = "\n".join(output)
            log = log or folder / "build.log"
            Path(log).write_text(text)
            tail = "\n".join(proc.stdout.strip().splitlines()[-5:])
            raise UserError(f"cannot build the FMU binary: '{' '.join(command[:2])} ...' failed "
                            f"(log: {log}):\n{tail}")
    return "\n".join(output)


def ensure_binaries(sanitize=False, cache_root=None, quiet=True) -> Binaries:
    """The FMU binaries for the current sources: reused from the cache or built now.

    Parameters
    ----------
    sanitize : bool
        Build with -fsanitize=address,undefined (for the C driver tests).
    cache_root : Path, optional
        Folder holding the builds (default ``cache_dir()/build``).
    quiet : bool
        Do not print that a build is running.
    """
    from ...cache import cache_dir
    root = Path(cache_root) if cache_root else cache_dir() / "build"
    key = build_key(sanitize)
    folder = root / key
    found = _binaries(folder, sanitize)
    if _complete(found):
        return found
    with _locked(root / f"{key}.lock"):
        found = _binaries(folder, sanitize)
        if _complete(found):
            return found
        if not quiet:
            print(f"building the FMU binaries (once; cached in {folder}) ...", file=sys.stderr)
        tmp = root / f"{key}.tmp-{os.getpid()}"
        shutil.rmtree(tmp, ignore_errors=True)
        try:
            output = configure_and_build(data_dir("fmu_src"), tmp, sanitize=sanitize)
            (tmp / "build.log").write_text(output)
            (tmp / "build.ok").write_text(key + "\n")
            shutil.rmtree(folder, ignore_errors=True)
            os.replace(tmp, folder)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    # CMake wrote absolute paths of the temporary folder into its cache; the
    # products themselves do not depend on it.
    return _binaries(folder, sanitize)

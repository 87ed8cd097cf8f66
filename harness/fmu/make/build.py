"""Build the FMU binaries from ``fmu_src/`` with CMake, once, and cache them: this platform's, and the other
platforms' an FMU carries where their cross compiler is installed.

The binaries do not depend on the scene (its numbers live in
``resources/model.bin``), so they are built once per source tree and fmpy
version and kept under ``$SPHROM_CACHE/build/<key>/`` (default
``~/.cache/sphrom/build``); packaging another scene needs no compiler.  The key
is a hash of every file in ``fmu_src/``, the fmpy version (its FMI headers),
the platform and the build flavour (release or sanitizer).  A build runs in a
temporary folder under a file lock and is renamed into place when complete,
so concurrent sessions never see half a build.

Every FMU carries this platform's binary (FMI 2 ``binaries/linux64/``, FMI 3 ``binaries/x86_64-linux/`` on x86-64
Linux) and one per platform of :data:`CROSS` whose compiler is on PATH: win64 (FMI 2 ``binaries/win64/``, FMI 3
``binaries/x86_64-windows/``), cross-compiled with MinGW-w64 (``x86_64-w64-mingw32-gcc``) by the same
``fmu_src/CMakeLists.txt`` and its one source list, cached under ``build/win64-<key>/`` (the key adds the
compiler's version).  :func:`fmu_binaries` gathers them and says, in one line each, which platform is missing and
why.  ``tests/test_fmu_platforms.py`` runs the win64 binary under wine and compares its outputs with this
platform's, bit for bit.
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

from ...cache import cache_dir
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
    loader : Path or None
        The FMU loader of the platform tests (tests/load.c).
    """

    folder: Path
    fmi2: Path
    fmi3: Path
    core: Path
    sph: Path
    driver: Path | None
    sanitize: bool
    loader: Path | None = None


@dataclass(frozen=True)
class Platform:
    """A platform an FMU carries a binary for.

    Attributes
    ----------
    name : str
        The FMI 2 platform folder's name (``linux64``, ``win64``), by which sphrom names the platform.
    title : str
        In words (``x86-64 Windows``).
    folders : tuple of str
        The binaries/ folder in FMI 2 and in FMI 3 (``win64``, ``x86_64-windows``).
    compiler : str
        The cross compiler looked for on PATH ("" for this platform: CMake's default compiler).
    cmake : tuple of str
        CMake options of the cross build (the target system).
    install : str
        How to install the compiler (the one line that says why a platform is missing).
    runner : str
        The program that runs the platform's executables here (``wine``; "" natively): the tests'.
    runner_install : str
        How to install the runner.
    library, executable : str
        The file name endings of a shared library and of a program (``.dll``, ``.exe``).
    """

    name: str
    title: str
    folders: tuple
    compiler: str = ""
    cmake: tuple = ()
    install: str = ""
    runner: str = ""
    runner_install: str = ""
    library: str = ".so"
    executable: str = ""

    def folder(self, fmi):
        """binaries/<folder> of FMI ``fmi``."""
        return self.folders[0] if fmi == 2 else self.folders[1]


WIN64 = Platform("win64", "x86-64 Windows", ("win64", "x86_64-windows"), compiler="x86_64-w64-mingw32-gcc",
                 cmake=("-DCMAKE_SYSTEM_NAME=Windows", "-DCMAKE_SYSTEM_PROCESSOR=AMD64"),
                 install="MinGW-w64, e.g. apt-get install gcc-mingw-w64-x86-64", runner="wine",
                 runner_install="wine, e.g. apt-get install wine64", library=".dll", executable=".exe")

# the platforms cross-compiled where their compiler is installed (besides this one)
CROSS = (WIN64,)


def native_platform() -> Platform:
    """This platform (fmpy's names: FMI 2 ``fmpy.platform``, FMI 3 ``fmpy.platform_tuple``)."""
    import platform

    import fmpy
    machine = platform.machine().lower().replace("amd64", "x86_64").replace("_", "-")
    system = {"linux": "Linux", "darwin": "macOS", "win32": "Windows"}.get(sys.platform, sys.platform)
    return Platform(fmpy.platform, f"{machine} {system}", (fmpy.platform, fmpy.platform_tuple),
                    library=fmpy.sharedLibraryExtension, executable=".exe" if sys.platform == "win32" else "")


@dataclass(frozen=True)
class PlatformBinaries:
    """One platform's FMI 2 and 3 binaries (and the tests' loader, when built).

    Attributes
    ----------
    platform : Platform
    fmi2, fmi3 : Path
    loader : Path or None
        tests/load.c built for the platform.
    cross : bool
        Cross-compiled (built with ``platform.compiler``).
    """

    platform: Platform
    fmi2: Path
    fmi3: Path
    loader: Path | None = None
    cross: bool = False

    def binary(self, fmi):
        return self.fmi2 if fmi == 2 else self.fmi3


@dataclass(frozen=True)
class FMUBinaries:
    """The binaries an FMU carries: this platform's first, then each cross-compiled one; and the platforms of
    :data:`CROSS` left out, with why.

    Attributes
    ----------
    builds : tuple of PlatformBinaries
    missing : tuple of (Platform, str)
        A platform left out and the reason ("x86_64-w64-mingw32-gcc not found on PATH (install ...)").
    """

    builds: tuple
    missing: tuple = ()

    def for_fmi(self, fmi):
        """{binaries/ folder: library path} of the FMI ``fmi`` FMU."""
        return {b.platform.folder(fmi): b.binary(fmi) for b in self.builds}

    @property
    def names(self):
        """The platforms carried (``["linux64", "win64"]``)."""
        return [b.platform.name for b in self.builds]

    def words(self):
        """The platforms carried, in words: "linux64 (x86-64 Linux), win64 (x86-64 Windows, cross-compiled with
        x86_64-w64-mingw32-gcc)"."""
        return ", ".join(f"{b.platform.name} ({b.platform.title}"
                         + (f", cross-compiled with {b.platform.compiler})" if b.cross else ")") for b in self.builds)

    def missing_lines(self):
        """One line per platform left out: "no win64 binary: ..."."""
        return [f"no {p.name} binary ({p.title}): {why}" for p, why in self.missing]


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


def _sources_key(build):
    """16 hex digits of the hash of every file of fmu_src/, the fmpy version (its FMI headers) and ``build`` (the
    words that name the build: platform, compiler, flavour)."""
    import fmpy
    root, files = source_files()
    digest = hashlib.sha256()
    for rel in files:
        digest.update(str(rel).encode() + b"\0" + (root / rel).read_bytes() + b"\0")
    digest.update(f"fmpy {fmpy.__version__}\n{build}".encode())
    return digest.hexdigest()[:16]


def build_key(sanitize=False):
    """Hash of the sources, the fmpy version, the platform and the flavour (16 hex digits)."""
    return _sources_key(f"{sys.platform}\n{BUILD_TYPE}\nsanitize={bool(sanitize)}")


def _library_name(stem):
    import fmpy
    return f"{stem}.{fmpy.sharedLibraryExtension.lstrip('.')}"


def _target_library(folder: Path, target):
    """The shared library CMake builds for ``target`` (lib<target>.so/.dylib, <target>.dll)."""
    return folder / (f"{target}.dll" if sys.platform == "win32" else _library_name(f"lib{target}"))


def _binaries(folder: Path, sanitize):
    exe = ".exe" if sys.platform == "win32" else ""
    driver, loader = folder / f"sphrom_driver{exe}", folder / f"sphrom_load{exe}"
    return Binaries(folder=folder, fmi2=folder / "fmi2" / _library_name("sphrom"),
                    fmi3=folder / "fmi3" / _library_name("sphrom"), core=_target_library(folder, "sphrom_core"),
                    sph=_target_library(folder, "sphrom_sph"), driver=driver if driver.exists() else None,
                    sanitize=sanitize, loader=loader if loader.exists() else None)


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


def configure_and_build(source: Path, folder: Path, sanitize=False, tests=True, log=None, options=(), targets=()):
    """Run CMake on ``source`` into ``folder`` (Release, -Wall -Wextra -Werror).

    ``options``: more configure options (a cross build's toolchain); ``targets``: the targets to build (default
    all).  Returns the combined output.  Raises UserError naming the log file when the configure or build step
    fails.
    """
    cmake = cmake_command()
    folder.mkdir(parents=True, exist_ok=True)
    configure = [cmake, "-S", str(source), "-B", str(folder), f"-DCMAKE_BUILD_TYPE={BUILD_TYPE}",
                 f"-DFMI_HEADERS_DIR={fmi_headers_dir()}", f"-DPython3_EXECUTABLE={sys.executable}",
                 f"-DSPHROM_SANITIZE={'ON' if sanitize else 'OFF'}", f"-DSPHROM_BUILD_TESTS={'ON' if tests else 'OFF'}",
                 *options]
    build = [cmake, "--build", str(folder), "--config", BUILD_TYPE, "--parallel", str(min(4, os.cpu_count() or 1)),
             *(["--target", *targets] if targets else [])]
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
    root = _build_root(cache_root)
    key = build_key(sanitize)
    folder = root / key
    _build_once(root, key, folder, lambda: _complete(_binaries(folder, sanitize)),
                lambda tmp: configure_and_build(data_dir("fmu_src"), tmp, sanitize=sanitize),
                "the FMU binaries", quiet)
    # CMake wrote absolute paths of the temporary folder into its cache; the
    # products themselves do not depend on it.
    return _binaries(folder, sanitize)


def _build_root(cache_root=None) -> Path:
    return Path(cache_root) if cache_root else cache_dir() / "build"


def _build_once(root: Path, key, folder: Path, complete, build, what, quiet):
    """Build into ``folder`` unless ``complete()``: ``build(tmp)`` (returning its log) in a temporary folder under
    the lock ``root/<key>.lock``, then renamed into place with build.log and build.ok."""
    if complete():
        return
    with _locked(root / f"{key}.lock"):
        if complete():
            return
        if not quiet:
            print(f"building {what} (once; cached in {folder}) ...", file=sys.stderr)
        tmp = root / f"{key}.tmp-{os.getpid()}"
        shutil.rmtree(tmp, ignore_errors=True)
        try:
            output = build(tmp)
            (tmp / "build.log").write_text(output)
            (tmp / "build.ok").write_text(key + "\n")
            shutil.rmtree(folder, ignore_errors=True)
            os.replace(tmp, folder)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)


def compiler_version(compiler) -> str:
    """The first line of ``compiler --version`` (part of a cross build's key), or "" when it does not run."""
    try:
        proc = subprocess.run([compiler, "--version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return ""
    lines = proc.stdout.strip().splitlines()
    return lines[0] if proc.returncode == 0 and lines else ""


def cross_key(platform: Platform, version: str):
    """Hash of the sources, the fmpy version, the target platform and its compiler's version (16 hex digits)."""
    return _sources_key(f"{platform.name}\n{version}\n{BUILD_TYPE}")


class PlatformUnavailable(Exception):
    """A cross build cannot be had here; the message says why in one line (the compiler missing, or its build
    failed and where the log is)."""


def _cross_products(folder: Path, platform: Platform):
    library = f"sphrom{platform.library}"
    loader = folder / f"sphrom_load{platform.executable}"
    return PlatformBinaries(platform, folder / "fmi2" / library, folder / "fmi3" / library,
                            loader=loader if loader.is_file() else None, cross=True)


def ensure_cross_binaries(platform: Platform = WIN64, cache_root=None, quiet=True) -> PlatformBinaries:
    """``platform``'s FMI 2 and 3 binaries (and the tests' loader), cross-compiled with its compiler from the
    current sources: reused from the cache (``build/<platform>-<key>/``) or built now (a few seconds).

    Raises
    ------
    PlatformUnavailable
        Its compiler is not on PATH, or its build failed (then the message names the log, kept as
        ``build/<platform>-<key>.failed.log``, and the build is not tried again for these sources and compiler).
    """
    compiler = shutil.which(platform.compiler)
    if compiler is None:
        raise PlatformUnavailable(f"{platform.compiler} not found on PATH (install {platform.install})")
    version = compiler_version(compiler)
    if not version:
        raise PlatformUnavailable(f"{compiler} does not run (its version query fails)")
    root = _build_root(cache_root)
    key = f"{platform.name}-{cross_key(platform, version)}"
    folder = root / key
    failed = root / f"{key}.failed.log"
    if failed.is_file():
        raise PlatformUnavailable(f"its build with {platform.compiler} failed (log: {failed})")
    source = data_dir("fmu_src")
    targets = ["sphrom_fmi2", "sphrom_fmi3"] + (["sphrom_load"] if (source / "tests" / "load.c").is_file() else [])

    def complete():
        found = _cross_products(folder, platform)
        return (folder / "build.ok").is_file() and found.fmi2.is_file() and found.fmi3.is_file()

    def build(tmp):
        return configure_and_build(source, tmp, log=failed, targets=targets,
                                   options=(*platform.cmake, f"-DCMAKE_C_COMPILER={compiler}"))
    try:
        _build_once(root, key, folder, complete, build, f"the {platform.name} FMU binaries with {platform.compiler}",
                    quiet)
    except UserError as exc:
        raise PlatformUnavailable(f"its build with {platform.compiler} failed (log: {failed}): "
                                  f"{str(exc).splitlines()[-1]}") from None
    return _cross_products(folder, platform)


def fmu_binaries(binaries: Binaries | None = None, cache_root=None, quiet=True) -> FMUBinaries:
    """The binaries an FMU carries: this platform's (``binaries``, or :func:`ensure_binaries`) and each platform of
    :data:`CROSS` whose compiler is installed (:func:`ensure_cross_binaries`); the others listed with why."""
    binaries = binaries or ensure_binaries(cache_root=cache_root, quiet=quiet)
    native = native_platform()
    builds = [PlatformBinaries(native, binaries.fmi2, binaries.fmi3, loader=binaries.loader)]
    missing = []
    for platform in CROSS:
        if platform.name == native.name:
            continue
        try:
            builds.append(ensure_cross_binaries(platform, cache_root=cache_root, quiet=quiet))
        except PlatformUnavailable as exc:
            missing.append((platform, str(exc)))
    return FMUBinaries(tuple(builds), tuple(missing))

"""Runs as self-describing HDF5 files, written atomically.

Layout (every solver: full SPH, reduced models, continuum references)::

    /t     (M,)    sample times                         [s]
    /x     (N,)    Lagrangian (reference) positions     [m]
    /v     (M, N)  velocity                             [m s^-1]
    /rho   (M, N)  density                              [kg m^-3]
    /steps (M,)    step index of each sample (when the solver has steps)

Each dataset has a ``units`` and a ``description`` attribute.  The root
attributes hold every scene parameter (``scene.*``: name, L, T and the field
expressions; the full TOML text in ``scene.toml``), the solver and its
settings (``solver``, ``solver.*``), the package version, the command line,
the creation time and the wall time [s].  Errors against references, when
computed, are stored as ``error.*`` attributes.

A file is written to a temporary name in the target folder and renamed at the
end, so an interrupted run leaves no half-written file.  An output path that is
not a regular file is never replaced: a character device (/dev/null), a FIFO or
an open descriptor (/dev/stdout) gets the finished bytes written into it, and a
folder, a block device or a socket is refused before any work
(:func:`check_output_path`).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import glob
import os
import re
import stat
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__
from .errors import FieldError, Interrupted
from .paths import not_a_file
from .signals import deferred, pending, record_written

FORMAT = "sphrom-run"
FORMAT_VERSION = 1

UNITS = {"t": "s", "x": "m", "v": "m s^-1", "rho": "kg m^-3", "steps": "1"}
DESCRIPTIONS = {
    "t": "sample times",
    "x": "Lagrangian (reference) positions of the samples",
    "v": "velocity v(x, t)",
    "rho": "density rho(x, t)",
    "steps": "time-step index of each sample",
}


@dataclass
class Run:
    """A run read back from (or to be written to) HDF5.  Shapes as above."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    rho: np.ndarray
    attrs: dict = field(default_factory=dict)
    steps: np.ndarray | None = None


# How long an output that is a FIFO waits at the end of the run for a process to open it for reading [s].
FIFO_WAIT_S = 30.0
TMP_MARK = ".tmp-"
_KINDS = {stat.S_IFREG: "file", stat.S_IFDIR: "folder", stat.S_IFCHR: "character device", stat.S_IFIFO: "FIFO",
          stat.S_IFBLK: "block device", stat.S_IFSOCK: "socket"}


def _shown(text, most=100):
    """A path for a one-line message: long ones shortened in the middle."""
    text = str(text)
    return text if len(text) <= most else f"{text[:most // 2]}...{text[-most // 4:]}"


def _field_of(path):
    """``cache`` for a path in the cache folder ($SPHROM_CACHE), else ``out``."""
    return "cache" if _in_cache(path) else "out"


def _in_cache(path):
    root = os.environ.get("SPHROM_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "sphrom")
    try:
        return os.path.commonpath([os.path.realpath(root), os.path.realpath(path)]) == os.path.realpath(root)
    except (ValueError, OSError):
        return False


def _via_descriptor(text):
    """Whether ``text`` is (a link to) an open descriptor: /dev/stdout, /dev/fd/N, /proc/PID/fd/N."""
    path = os.path.abspath(text)
    for _ in range(40):
        if re.fullmatch(r"/proc/[^/]+/fd/\d+|/dev/fd/\d+", path):
            return True
        if not os.path.islink(path):
            return False
        path = os.path.abspath(os.path.join(os.path.dirname(path), os.readlink(path)))
    return False


def output_target(path, field="out"):
    """How an output at ``path`` is written, decided from what the path is now (symbolic links followed).

    Returns
    -------
    ("replace", Path)
        Nothing there yet, or a regular file: written to a temporary beside the returned path (``path`` with
        its links resolved, so that a link stays a link) and renamed over it.
    ("into", kind)
        A character device (/dev/null), a FIFO, or an open descriptor (/dev/stdout): the bytes are written
        into the node, which stays what it was; ``kind`` is ``character device``, ``FIFO`` or ``descriptor``.

    Raises FieldError ``field`` for a folder, a block device, a socket, a path the system refuses (a NUL
    character, a link loop, a component that is not a folder).
    """
    text = os.fspath(path)
    if not text:
        raise FieldError(field, "empty path (allowed: a file path)")
    if "\0" in text:
        raise FieldError(field, f"{text!r} holds a NUL character (allowed: a file path)")
    try:
        st = os.stat(text)
    except FileNotFoundError:
        st = None
    except NotADirectoryError:
        raise FieldError(field, f"'{_shown(text)}': a part of the path is not a folder") from None
    except OSError as exc:
        raise FieldError(field, f"'{_shown(text)}': {exc.strerror or exc}") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        kind = _KINDS.get(stat.S_IFMT(st.st_mode), "special file")
        if kind in ("character device", "FIFO"):
            return "into", kind
        raise FieldError(field, f"'{text}' is a {kind} (allowed: a file path, a character device or a FIFO; "
                                f"nothing there is replaced)")
    if st is not None and _via_descriptor(text):
        return "into", "descriptor"
    try:
        return "replace", Path(os.path.realpath(text))
    except (OSError, ValueError) as exc:
        raise FieldError(field, f"'{text}': {exc}") from None


def _temporary(target):
    return target.with_name(f".{target.name}{TMP_MARK}{os.getpid()}")


def check_output_path(path, field="out"):
    """Fail early (before any work) when ``path`` cannot be written; returns it as a Path.

    Allowed: a new file in an existing folder, a regular file (replaced at the end), a character device or a
    FIFO (written into, never replaced: see :func:`atomic_path`).  The folder is tested by creating and
    removing the very temporary the write will use (``os.access`` says yes to root on /proc and /sys, and
    knows nothing of name lengths).  Raises FieldError ``field`` for a trailing ``/`` (a folder's name), a
    folder, a block device, a socket, a missing folder, a folder where no file can be created, or a name
    the system refuses.
    """
    text = os.fspath(path)
    if text and re.split(r"/+", text)[-1] in ("", ".", ".."):
        raise FieldError(field, f"'{text}' names a folder (allowed: a file path, without a trailing '/')")
    how, target = output_target(text, field)
    if how == "into":
        if target == "character device":
            try:
                os.close(os.open(text, os.O_WRONLY | os.O_NONBLOCK))
            except OSError as exc:
                raise FieldError(field, f"cannot write into '{text}' ({exc.strerror or exc})") from None
        return Path(text)
    parent = target.parent
    if not parent.is_dir():
        raise FieldError(field, f"folder '{Path(text).parent}' does not exist")
    tmp = _temporary(target)
    try:
        with deferred():                # a signal between the create and the unlink would leave the probe behind
            with contextlib.suppress(FileNotFoundError):
                if tmp.is_symlink() or tmp.is_file():
                    tmp.unlink()                               # this process's own, from an earlier write
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600))
            tmp.unlink()
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise FieldError(field, f"'{target.name[:40]}...' is too long a file name for this system (with its "
                                    f"temporary '.NAME{TMP_MARK}PID', {len(os.fsencode(tmp.name))} bytes)") from None
        raise FieldError(field, f"cannot create a file in folder '{parent}' ({exc.strerror or exc})") from None
    return Path(text)


def _missing_folders(path):
    """The folders of ``path`` (itself included) that do not exist yet, outermost first, and the nearest one
    that does."""
    missing = []
    p = Path(os.path.abspath(path))
    while not os.path.lexists(p) and p != p.parent:
        missing.append(p)
        p = p.parent
    return missing[::-1], p


def check_output_dir(path, field="out"):
    """Fail early (before any work) unless ``path`` is a folder, or can be made one, where files can be
    created; returns it as a Path (the folder is not made here: :func:`output_dir`).

    Raises FieldError ``field`` for an existing path that is not a folder (a file, a device, a FIFO), a
    name the system refuses (too long, a NUL), or a folder where no file can be created (/proc, /sys, a
    read-only one: tested by creating a file, as :func:`check_output_path`).
    """
    text = os.fspath(path)
    if not text or "\0" in text:
        raise FieldError(field, f"{text!r} is not a folder name (allowed: a folder path)")
    missing, existing = _missing_folders(text)
    try:
        st = os.stat(existing)
    except OSError as exc:
        raise FieldError(field, f"'{text}': {exc.strerror or exc}") from None
    if not stat.S_ISDIR(st.st_mode):
        kind = _KINDS.get(stat.S_IFMT(st.st_mode), "special file")
        where = "" if not missing else f" (its part '{existing}')"
        raise FieldError(field, f"'{text}' is a {kind}{where} (allowed: a folder, made when missing)")
    for folder in missing:
        if len(os.fsencode(folder.name)) > 255:
            raise FieldError(field, f"'{folder.name[:40]}...' is too long a folder name for this system")
    probe = Path(existing) / f".sphrom-probe{TMP_MARK}{os.getpid()}"
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600))
        probe.unlink()
    except OSError as exc:
        raise FieldError(field, f"cannot create a file in folder '{existing}' ({exc.strerror or exc})") from None
    return Path(text)


@contextlib.contextmanager
def output_dir(path, field="out"):
    """The folder ``path`` (checked by :func:`check_output_dir`, made with its missing parents) for the block;
    on an exception the folders it made are removed again when still empty (nothing left behind)."""
    check_output_dir(path, field)
    missing, _ = _missing_folders(path)
    made = []
    try:
        for folder in missing:
            folder.mkdir()
            made.append(folder)
    except OSError as exc:
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise FieldError(field, f"cannot make folder '{path}' ({exc.strerror or exc})") from None
    try:
        yield Path(path)
    except BaseException:
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True              # someone else's live process
    return True


def sweep_stale_temporaries(path):
    """Remove temporaries of ``path`` left by processes that no longer run.

    A run killed by SIGKILL cannot remove its temporary ``.NAME.tmp-PID``;
    the next write of the same output removes it when PID is dead (a live
    writer's temporary is left alone).  Returns the removed paths.
    """
    path = Path(path)
    prefix = f".{path.name}{TMP_MARK}"
    removed = []
    try:
        siblings = list(path.parent.glob(f"{glob.escape(prefix)}*"))
    except OSError:
        return removed
    for tmp in siblings:
        pid_text = tmp.name[len(prefix):].split("-")[0]
        if not pid_text.isdigit():
            continue
        pid = int(pid_text)
        if pid != os.getpid() and _pid_alive(pid):
            continue
        with contextlib.suppress(OSError):
            tmp.unlink()
            removed.append(tmp)
    return removed


def _commit(items):
    """Rename each (temporary, target, shown) whose temporary exists, all or none as far as signals go: a
    signal arriving meanwhile is held until every rename is done (and then reported as after the write); a
    signal received earlier whose exception was lost (:func:`sphrom.signals.pending`) stops them all."""
    with deferred():
        signum = pending()
        if signum is not None:
            raise Interrupted(signum)
        for tmp, target, shown in items:
            if os.path.lexists(tmp):
                os.replace(tmp, target)
                if not _in_cache(target):
                    record_written(shown)


def _open_fifo(node, field):
    """A blocking write descriptor of FIFO ``node`` once a reader has it open (at most FIFO_WAIT_S)."""
    deadline = time.monotonic() + FIFO_WAIT_S
    while True:
        try:
            fd = os.open(node, os.O_WRONLY | os.O_NONBLOCK)
            break
        except OSError as exc:
            if exc.errno != errno.ENXIO:
                raise
            if time.monotonic() > deadline:
                raise FieldError(field, f"no process opened the FIFO '{node}' for reading within {FIFO_WAIT_S:g} s; "
                                        "nothing was written into it") from None
            time.sleep(0.02)
    os.set_blocking(fd, True)
    return fd


def _write_into(node, tmp, kind, field):
    """Copy the finished temporary ``tmp`` into the node ``node`` (a device, a FIFO, a descriptor)."""
    with deferred():
        signum = pending()
        if signum is not None:
            raise Interrupted(signum)
    size = os.path.getsize(tmp)
    sent = 0
    try:
        if kind == "FIFO":
            fd = _open_fifo(node, field)
        else:
            append = kind == "descriptor" and stat.S_ISREG(os.stat(node).st_mode)
            fd = os.open(node, os.O_WRONLY | (os.O_APPEND if append else 0))
    except OSError as exc:
        raise FieldError(field, f"cannot write into '{node}' ({exc.strerror or exc})") from None
    try:
        with open(tmp, "rb") as src:
            while chunk := src.read(1 << 20):
                view = memoryview(chunk)
                while view:
                    n = os.write(fd, view)
                    sent += n
                    view = view[n:]
    except BrokenPipeError:
        raise FieldError(field, f"the reader of '{node}' closed it after {sent} of {size} bytes") from None
    except OSError as exc:
        raise FieldError(field, f"cannot write into '{node}' ({exc.strerror or exc}; {sent} of {size} bytes "
                                "written)") from None
    except Interrupted as exc:
        if sent:
            raise Interrupted(exc.signum, note=f"'{node}' received {sent} of its {size} bytes") from None
        raise
    finally:
        os.close(fd)
    record_written(node)


@contextlib.contextmanager
def h5_create(path):
    """A new HDF5 file for writing at ``path`` (a temporary of :func:`atomic_path`), built in memory and written
    to ``path`` by Python when the block ends.

    HDF5 writing to a full file system failed inside h5py's finalisers (tracebacks printed as "Exception
    ignored", then SIGSEGV, the temporary left behind); in memory, the only write to the disk is
    Python's, whose ENOSPC is an OSError that :func:`atomic_paths` turns into one line.  The file's bytes are
    held twice for a moment (the image and its copy), as large as the arrays the command already holds.
    """
    import h5py
    h5 = h5py.File(f"sphrom-memory-{id(path)}.h5", "w", driver="core", backing_store=False)
    try:
        yield h5
        h5.flush()
        image = h5.id.get_file_image()
    finally:
        h5.close()
    with open(path, "wb") as fh:
        fh.write(image)


NO_SPACE = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def _no_space(exc, path, field):
    """FieldError ``field`` for a write that found the file system full (ENOSPC, a quota, a size limit)."""
    try:
        st = os.statvfs(Path(path).parent)
        free = f" (a file system of {format_bytes(st.f_blocks * st.f_frsize)})"
    except OSError:
        free = ""
    return FieldError(field, f"cannot write '{path}': {os.strerror(exc.errno).lower()}{free}; nothing was "
                             "written (free some space or choose another folder)")


def format_bytes(n):
    """``n`` bytes as text in binary units: 512 B, 64 KiB, 8.9 GiB."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1024


def available_memory():
    """Bytes this process may still allocate, the least of what the system has available (MemAvailable),
    what its address-space limit leaves (RLIMIT_AS less the current size) and what its cgroup's memory.max
    leaves; None where none can be read (not Linux)."""
    import resource
    limits = []
    with contextlib.suppress(OSError, ValueError, IndexError):
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                limits.append(int(line.split()[1]) * 1024)
    with contextlib.suppress(OSError, ValueError, IndexError):
        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft != resource.RLIM_INFINITY:
            size = next(int(line.split()[1]) * 1024 for line in Path("/proc/self/status").read_text().splitlines()
                        if line.startswith("VmSize:"))
            limits.append(max(soft - size, 0))
    with contextlib.suppress(OSError, ValueError):
        top = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if top != "max":
            limits.append(max(int(top) - int(Path("/sys/fs/cgroup/memory.current").read_text()), 0))
    return min(limits) if limits else None


def check_memory(field, need, what):
    """FieldError ``field`` when ``need`` bytes (``what``: the text that says what they hold and why) exceed
    :func:`available_memory`, before the work starts."""
    free = available_memory()
    if free is not None and need > free:
        raise FieldError(field, f"{what} needs about {format_bytes(need)} of memory, and this machine has "
                                f"{format_bytes(free)} available (allowed: a run that fits)")


# Bytes per particle and stored sample of a run's samples: v and rho, float64 (sphrom.sph.solver.run_sph)
SAMPLE_BYTES = 16
# The comparison with the exact solution (sphrom sph, scenes with uniform c, rho0, d): the reference's v and rho, the
# complex synthesis of each (bins, inverse FFT) and the error's differences, float64 per particle and sample
EXACT_BYTES = 96
# The POD of the snapshots (sphrom.pod): the snapshot matrices of v and rho, the SVD's copies and its left
# vectors, float64 per particle and snapshot
POD_BYTES = 64
# The bar's lowest modes above MODAL_DENSE_N particles (sphrom.rom.inputs.bar_modes: shift-invert Lanczos of
# MODAL_SPARSE modes): ARPACK's 2 MODAL_SPARSE + 1 Lanczos vectors, the modes, and the channel's modal responses
# and their copies (sphrom.rom.inputs.channel_modes), float64 per particle: 601 + 3 x 300 vectors
MODAL_VECTORS = 2 * 300 + 1 + 3 * 300
# The frozen model's refresh tensor (sphrom.rom.operators.refresh_tensor): the products of U^rho over every sorted
# index triple at every particle, k(k+1)(k+2)/6 columns, and the two temporaries of the product, float64
TENSOR_COPIES = 3
# At most MODAL_DENSE_N particles the modes and the error bounds' shadow are dense: about six matrices of (2N)^2
DENSE_BYTES = 6 * 4 * 8
# The need against what is available: an address-space limit counts what the allocator reserves, not only what a
# run touches, and a sparse LU (SuperLU, in the modes' shift-invert) that cannot allocate ends the process
# (SIGSEGV) instead of raising MemoryError: a quarter more is asked than the arrays hold
MEMORY_MARGIN = 1.25


def run_memory(scene, command, model=None, modes=None):
    """The largest allocations that grow with the particles N of ``command`` (``sph``, ``pod``, ``fmu``) on
    ``scene``, before any of its work: a list of (bytes, what they hold).  An estimate from the arrays' sizes
    (float64): the run's stored samples, the exact solution they are compared with (``sph``), the POD of the
    snapshots and the frozen model's refresh tensor (``pod``, ``fmu`` with a model that has one; ``modes`` the k
    asked for, else the scene's or the automatic rule's largest), the bar's modes and the error bounds' shadow
    (``fmu``); the interpreter and the
    libraries (about 0.3 GiB) are not in it.  ``tests/test_hostile_round4.py`` checks it against the peak
    measured."""
    from .sph.solver import default_sample_steps, step_count
    n = int(scene.sph.n_particles)
    samples = int(default_sample_steps(step_count(scene.T, scene.sph.dt), scene.sph.every).size)
    needs = [(SAMPLE_BYTES * samples * n, f"the run's {samples} samples of v and rho")]
    if command == "sph":
        from .references.exact import is_available
        if is_available(scene):
            needs.append((EXACT_BYTES * samples * n, "the exact solution they are compared with"))
    if command in ("pod", "fmu"):
        count = int(scene.snapshots.get("count", 0)) or samples
        needs.append((POD_BYTES * count * n, f"the POD of {count} snapshots"))
    if command in ("pod", "fmu") and not (model and _linear(model)):
        from .pod.automatic import MAX_AUTO_MODES
        count = int(scene.snapshots.get("count", 0)) or samples
        k = int(modes or scene.rom.get("modes") or min(MAX_AUTO_MODES, count)) + 1     # + 1: an appended direction
        needs.append((8 * TENSOR_COPIES * n * (k * (k + 1) * (k + 2) // 6),
                      f"the frozen model's refresh tensor of {k} density modes"))
    if command == "fmu":
        from .rom.inputs import MODAL_DENSE_N
        if n <= MODAL_DENSE_N:
            needs.append((DENSE_BYTES * n * n, "the dense modes and error bounds' shadow of 2N states"))
        else:
            needs.append((8 * MODAL_VECTORS * n, "the bar's lowest 300 modes (shift-invert Lanczos)"))
    return needs


def _linear(model):
    """Whether the registered reduced model ``model`` is a linear one (no refresh tensor); False for "auto"."""
    from .rom.registry import MODELS
    spec = MODELS.get(model)
    return bool(spec and spec.linear)


def check_run_memory(scene, command, model=None, modes=None, field="n_particles"):
    """FieldError ``field`` (the scene's sph.n_particles) when :func:`run_memory` of ``command`` on ``scene`` exceeds
    what this machine has available (:func:`available_memory`) with :data:`MEMORY_MARGIN`, before the work
    starts: one line with the need, what holds most of it, what is available and the largest N that fits here.
    ``sphrom sph``, ``pod`` and ``fmu`` call it once their scene is known."""
    free = available_memory()
    if free is None:
        return
    needs = run_memory(scene, command, model, modes)
    total = MEMORY_MARGIN * sum(b for b, _ in needs)
    if total <= free:
        return
    n = int(scene.sph.n_particles)
    low, high = 0, n                                 # the largest N whose need fits (the need grows with N)
    while high - low > 1:
        mid = (low + high) // 2
        if MEMORY_MARGIN * sum(b for b, _ in run_memory(_with_particles(scene, mid), command, model, modes)) <= free:
            low = mid
        else:
            high = mid
    biggest = max(needs)[1]
    raise FieldError(field, f"N = {n} particles need about {format_bytes(total)} of memory (most of it {biggest}), "
                            f"and this machine has {format_bytes(free)} available (allowed: N up to {low} here, with "
                            "these steps and samples)")


def _with_particles(scene, n):
    import dataclasses
    return dataclasses.replace(scene, sph=dataclasses.replace(scene.sph, n_particles=max(int(n), 1)))


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path; on success it becomes ``path``, else nothing is left.

    A new file or a regular file: the temporary is beside it (beside its target when ``path`` is a link) and
    is renamed over it.  A character device, a FIFO or an open descriptor (/dev/null, a named pipe,
    /dev/stdout): the temporary is in a private folder and its bytes are written into the node, which stays
    a node (a FIFO waits up to :data:`FIFO_WAIT_S` for a reader).  On any exception (including
    KeyboardInterrupt) the temporary is removed and ``path`` is left as it was.  SIGINT and SIGTERM arriving
    while the block writes are held until it ends and then delivered before the rename (never swallowed); a
    signal whose exception was lost earlier stops the rename (:func:`sphrom.signals.pending`).  Temporaries
    of ``path`` left by killed processes are removed first (:func:`sweep_stale_temporaries`).
    """
    path = Path(path)
    field = _field_of(path)
    how, target = output_target(path, field)
    if how == "into":
        with tempfile.TemporaryDirectory(prefix="sphrom-out-") as folder:
            tmp = Path(folder) / (path.name or "out")
            try:
                with deferred():
                    yield tmp
            except OSError as exc:
                if exc.errno in NO_SPACE:
                    raise _no_space(exc, tmp, field) from None
                raise
            _write_into(path, tmp, target, field)
        return
    with atomic_paths([path]) as (tmp,):
        yield tmp


@contextlib.contextmanager
def atomic_paths(paths):
    """Temporaries for several outputs written together: all are renamed at the end, or none.

    Each path must be new or a regular file (FieldError ``out`` otherwise).  A temporary the block did not
    create leaves its path as it was (an optional output, e.g. a plot that could not be drawn).
    """
    items = []
    for path in map(Path, paths):
        field = _field_of(path)
        how, target = output_target(path, field)
        if how != "replace":
            raise FieldError(field, f"'{path}' is a {target} (allowed here: a file path; outputs written together "
                                    "are renamed into place)")
        sweep_stale_temporaries(target)
        items.append((_temporary(target), target, path))
    try:
        try:
            with deferred():
                yield [tmp for tmp, _, _ in items]
        except OSError as exc:
            if exc.errno in NO_SPACE:
                raise _no_space(exc, items[0][2], _field_of(items[0][2])) from None
            raise
        _commit(items)
    finally:
        for tmp, _, _ in items:
            if os.path.lexists(tmp):
                tmp.unlink()


def save_figure(fig, path, **kwargs):
    """``fig.savefig`` through :func:`atomic_path` (a PNG unless ``format`` says otherwise): never half a
    plot, never a node replaced."""
    kwargs.setdefault("format", Path(path).suffix.lstrip(".").lower() or "png")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, **kwargs)


def scene_attrs(scene):
    """Root attributes describing a scene (``scene.*``)."""
    attrs = {
        "scene.name": scene.name,
        "scene.section": scene.section,
        "scene.source": str(scene.source),
        "scene.toml": scene.text,
        "scene.L": scene.L,
        "scene.T": scene.T,
    }
    for name, expr in scene.fields.items():
        attrs[f"scene.{name}"] = expr.text
    attrs["scene.f"] = scene.f.text
    for key, value in vars(scene.sph).items():
        attrs[f"scene.sph.{key}"] = value
    return attrs


def _clean(value):
    if value is None:
        return "none"
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if isinstance(value, (list, tuple)):
        return np.asarray(value)
    return value


def write_run(path, t, x, v, rho, attrs, steps=None, extra=None):
    """Write a run to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
    t, x, v, rho : ndarray
        See the module docstring for shapes and units.
    attrs : dict
        Root attributes (scene, solver, timings, errors); values must be
        numbers, strings or arrays of numbers.
    steps : ndarray of int, optional
    extra : dict of name -> ndarray, optional
        Additional datasets (e.g. reduced coordinates).
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    v, rho = np.asarray(v, float), np.asarray(rho, float)
    if v.shape != (t.size, x.size) or rho.shape != v.shape:
        raise ValueError(f"shapes: t {t.shape}, x {x.shape}, v {v.shape}, rho {rho.shape}")
    base = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "sphrom_version": __version__,
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join(sys.argv),
    }
    with atomic_path(path) as tmp:
        import h5py                           # here, not at the top: paths-only callers (cosim) stay light
        with h5_create(tmp) as h5:
            for key, value in {**base, **attrs}.items():
                h5.attrs[key] = _clean(value)
            data = {"t": t, "x": x, "v": v, "rho": rho}
            if steps is not None:
                data["steps"] = np.asarray(steps, dtype=np.int64)
            for name, arr in data.items():
                ds = h5.create_dataset(name, data=arr, compression="gzip" if arr.size > 4096 else None)
                ds.attrs["units"] = UNITS[name]
                ds.attrs["description"] = DESCRIPTIONS[name]
            for name, arr in (extra or {}).items():
                h5.create_dataset(name, data=np.asarray(arr))


def read_run(path) -> Run:
    """Read a run written by :func:`write_run`.

    Raises FieldError ``run`` when the file is missing or not a sphrom run.
    """
    path = Path(path)
    if not path.is_file():
        raise FieldError("run", f"'{path}': {not_a_file(path)}")
    try:
        import h5py
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != FORMAT:
                raise FieldError("run", f"'{path}': not a sphrom run file (format attribute missing)")
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h5.attrs.items()}
            steps = h5["steps"][()] if "steps" in h5 else None
            return Run(t=h5["t"][()], x=h5["x"][()], v=h5["v"][()], rho=h5["rho"][()], attrs=attrs, steps=steps)
    except OSError as exc:
        raise FieldError("run", f"'{path}': cannot be read as HDF5 ({exc})") from None

"""Where the repository's data folders are, in a checkout or an installed wheel.

In a checkout (and an editable install) they are the top-level folders
``validation/scenes``, ``fmu_src`` and ``modelDescription``; a wheel ships them
as the packages ``sphrom.scenes``, ``sphrom.fmu_src`` and
``sphrom.model_description`` (see pyproject.toml).
"""

import errno
import importlib.util
import os
from pathlib import Path

_REPO = Path(__file__).resolve().parents[1]
_CHECKOUT = Path(__file__).resolve().parent.name == "harness"     # installed, the package's folder is sphrom/
_LAYOUT = {
    "scenes": ("validation/scenes", "sphrom.scenes"),
    "fmu_src": ("fmu_src", "sphrom.fmu_src"),
    "model_description": ("modelDescription", "sphrom.model_description"),
}


def data_dir(kind: str) -> Path:
    """The folder of ``kind`` (scenes, fmu_src, model_description)."""
    rel, package = _LAYOUT[kind]
    candidate = _REPO / rel
    if _CHECKOUT and candidate.is_dir():
        return candidate
    # An installed data folder is a namespace package (no __init__.py): importlib.resources.files() gives a
    # MultiplexedPath whose str() is no path, so take the folder from the package's search locations.
    spec = importlib.util.find_spec(package)
    for location in (spec.submodule_search_locations or []) if spec else []:
        if Path(location).is_dir():
            return Path(location)
    raise FileNotFoundError(f"sphrom's {kind} folder is missing from this installation (package {package})")


def repo_root() -> Path:
    """The repository root when running from a checkout (else the install dir)."""
    return _REPO


def is_file(path) -> bool:
    """Whether ``path`` names an existing file; False, never OSError or ValueError,
    for a name the system refuses (too long, a NUL character)."""
    try:
        return Path(path).is_file()
    except (OSError, ValueError):
        return False


def not_a_file(path) -> str:
    """Why ``path`` cannot be read as an input file, for a one-line error: "not found", or what it is instead
    ("is a folder", "is a FIFO", ...: a path that exists but is no regular file is no "not found")."""
    import stat
    try:
        mode = os.stat(path).st_mode
    except ValueError:
        return "not a possible file name"
    except OSError as exc:
        return "not found" if exc.errno in (errno.ENOENT, errno.ENOTDIR) else f"cannot be read ({exc.strerror})"
    for test, what in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return f"is {what} (allowed: a regular file)"
    return "not a regular file"


def exists(path) -> bool:
    """Whether ``path`` exists; False for a name the system refuses (see :func:`is_file`)."""
    try:
        return Path(path).exists()
    except (OSError, ValueError):
        return False


def import_path(checkout) -> str:
    """A folder in which ``sphrom`` is a link to ``checkout/harness``: first on ``PYTHONPATH`` (or sys.path), a
    process imports that checkout's code as ``sphrom`` whatever is installed (the import package lives in the
    folder harness/, pyproject.toml maps it).  One folder per checkout in the temporary folder, made once and
    reused, so that repeated calls leave nothing more behind."""
    import hashlib
    import os
    import tempfile
    target = (Path(checkout).resolve() / "harness")
    if not (target / "__init__.py").is_file():
        raise FileNotFoundError(f"{checkout}: not a sphrom checkout (no harness/__init__.py)")
    key = hashlib.sha256(str(target).encode()).hexdigest()[:16]
    folder = Path(tempfile.gettempdir()) / f"sphrom-import-{os.getuid() if hasattr(os, 'getuid') else 0}-{key}"
    link = folder / "sphrom"
    if not link.is_symlink():
        folder.mkdir(parents=True, exist_ok=True)
        try:
            link.symlink_to(target, target_is_directory=True)
        except FileExistsError:            # another process made it meanwhile
            pass
    return str(folder)

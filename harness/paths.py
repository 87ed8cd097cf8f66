"""Where the repository's data folders are, in a checkout or an installed wheel.

In a checkout (and an editable install) they are the top-level folders
``validation/scenes``, ``fmu_src`` and ``modelDescription``; a wheel ships them
as the packages ``harness.scenes``, ``harness.fmu_src`` and
``harness.model_description`` (see pyproject.toml).
"""

from importlib import resources
from pathlib import Path

_REPO = Path(__file__).resolve().parents[1]
_LAYOUT = {
    "scenes": ("validation/scenes", "harness.scenes"),
    "fmu_src": ("fmu_src", "harness.fmu_src"),
    "model_description": ("modelDescription", "harness.model_description"),
}


def data_dir(kind: str) -> Path:
    """The folder of ``kind`` (scenes, fmu_src, model_description)."""
    rel, package = _LAYOUT[kind]
    candidate = _REPO / rel
    if candidate.is_dir():
        return candidate
    return Path(str(resources.files(package)))


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


def exists(path) -> bool:
    """Whether ``path`` exists; False for a name the system refuses (see :func:`is_file`)."""
    try:
        return Path(path).exists()
    except (OSError, ValueError):
        return False

"""The part the reference-data generators share: run the harness of another checkout (the code before a change).

A generator stores outputs of an older checkout (``--code PATH``) for a test to compare today's binaries with;
:func:`use_checkout` puts that checkout's package and tests first on sys.path, gives the run a private SPH cache,
and checks that the package imported is the one asked for.  The import package ``sphrom`` lives in the folder
``harness/`` (pyproject.toml maps it): :func:`import_path` gives a folder in which ``sphrom`` is a link to a
checkout's ``harness/``, for sys.path or PYTHONPATH.
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path


def use_checkout(description):
    """Parse ``--code`` (default: this repository), put its harness first on sys.path; returns its root."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--code", default=str(Path(__file__).resolve().parents[2]),
                        help="the checkout whose harness runs (default: this repository)")
    root = Path(parser.parse_args().code).resolve()
    sys.path[:0] = [import_path(root), str(root / "tests")]
    os.environ.setdefault("SPHROM_CACHE", tempfile.mkdtemp(prefix="sphrom-cache-"))
    import sphrom
    assert Path(sphrom.__file__).resolve().parents[1] == root, sphrom.__file__
    return root


def import_path(root):
    """A new temporary folder holding ``sphrom``, a link to ``root/harness``: put first on sys.path (or PYTHONPATH),
    ``import sphrom`` imports that checkout's code whatever is installed."""
    folder = Path(tempfile.mkdtemp(prefix="sphrom-import-"))
    (folder / "sphrom").symlink_to(Path(root).resolve() / "harness", target_is_directory=True)
    return str(folder)

"""The part the reference-data generators share: run the harness of another checkout (the code before a change).

A generator stores outputs of an older checkout (``--code PATH``) for a test to compare today's binaries with;
:func:`use_checkout` puts that checkout's harness and tests first on sys.path, gives the run a private SPH cache,
and checks that the harness imported is the one asked for.
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
    sys.path[:0] = [str(root), str(root / "tests")]
    os.environ.setdefault("SPHROM_CACHE", tempfile.mkdtemp(prefix="sphrom-cache-"))
    import harness
    assert Path(harness.__file__).resolve().parents[1] == root, harness.__file__
    return root

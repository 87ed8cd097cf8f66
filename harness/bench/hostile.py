"""``sphrom bench hostile``: an alias of the hostile-input battery, which is a test-side tool in a checkout's
``tests/hostile/`` (``python3 -m tests.hostile``), not a measurement program.

From a checkout it says where the battery lives and runs it with the same arguments; outside a checkout (an
installed wheel) it refuses in one line, exit status 2.
"""

from __future__ import annotations

import sys
from pathlib import Path

from tests.hostile.battery import main as battery_main


def checkout():
    """The checkout that holds this code's ``tests/hostile/``, else None (an installed package)."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / "tests" / "hostile" / "battery.py").is_file() else None


def main(argv=None):
    root = checkout()
    if root is None:
        print("sphrom bench hostile: error: the hostile-input battery is a test-side tool in a checkout's "
              "tests/hostile/ (python3 -m tests.hostile from the checkout); this installation has none",
              file=sys.stderr)
        return 2
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    return battery_main(argv, prog="sphrom bench hostile")


if __name__ == "__main__":
    sys.exit(main())

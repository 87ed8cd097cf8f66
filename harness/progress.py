"""Progress bars for long work (tqdm), shown only when a run lasts > 2 s."""

import contextlib
import sys

from tqdm.auto import tqdm


class _Null:
    def update(self, n=1):
        pass

    def set_postfix_str(self, s):
        pass


@contextlib.contextmanager
def progress_bar(total, desc, unit="it", enabled=True):
    """A tqdm bar on stderr that appears after 2 s of work (never on short runs).

    ``enabled=False`` gives a no-op bar (tests, ``--quiet``).
    """
    if not enabled:
        yield _Null()
        return
    bar = tqdm(total=total, desc=desc, unit=unit, delay=2.0, file=sys.stderr, leave=False,
               dynamic_ncols=True, unit_scale=bool(total and total >= 10_000))   # "200k" steps, "3/8" runs
    try:
        yield bar
    finally:
        bar.close()

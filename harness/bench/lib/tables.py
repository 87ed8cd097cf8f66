"""CSV files of the benchmarks, written atomically (a temporary name, then rename)."""

import csv
import io

from ...markdown import write_text


def write_csv(path, rows, fields=None):
    """``rows`` (dicts) as CSV at ``path``; ``fields`` (default: every key, in order of appearance) with the
    keys outside them left out."""
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=fields or list(dict.fromkeys(k for r in rows for k in r)),
                       extrasaction="ignore" if fields else "raise")
    w.writeheader()
    w.writerows(rows)
    write_text(path, buf.getvalue())

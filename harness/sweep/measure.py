"""``python -m sphrom.sweep.measure``: the old name of ``sphrom bench sweep`` (:mod:`sphrom.bench.sweep`), kept as an
alias; it runs that program with the same options.

A launcher only: nothing imports it and it imports nothing of :mod:`sphrom.bench` (the sweep library stays below
the measurement programs); run as a script it hands over to the program.
"""

import runpy

if __name__ == "__main__":
    runpy.run_module("sphrom.bench.sweep", run_name="__main__", alter_sys=True)

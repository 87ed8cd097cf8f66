"""The hostile-input battery, a test-side tool (not a measurement program): every command's options, scenes,
output paths, damaged FMUs, full disks, memory limits, mutated FMU resources and states, FMI calls out of order,
and signals at random moments of every long command.

    python3 -m tests.hostile [--out validation/hostile] [--seed 25] [--jobs 2] [--quick]
    python3 -m tests.hostile signals [--sweeps 50] [--terms 200]     (the signal trials alone)

Run from a checkout (the folder that holds ``tests/``); ``sphrom bench hostile`` is an alias of the first line.
The suite runs small samples of it (``tests/test_hostile*.py``).
"""

"""The measurement library that the benchmark programs (:mod:`sphrom.bench`) and the commands share.

Nothing here is a program.  ``timing`` (medians on a noisy machine), ``tables`` (CSV), ``markdown`` (the sections
of BENCHMARKS.md and stress.md), ``methods`` (run time against error of every method), ``scaling``, ``skip``,
``sph_scaling``, ``input_direction`` (the tables of ``sphrom bench``), ``suite`` (all of them in one run),
``fmu`` (the FMU's timings: the C core, end to end, the FMU rows), ``stress``, ``stress_fmu``, ``stress_maps``,
``stress_settings`` (the stability maps), ``hostile_fmu`` (the hostile battery's FMU cases), ``ports`` (the
port forces and lumped component the port benchmarks share), ``responses`` (a reduced model under inputs held
over communication steps: the input benchmarks' and tests' run).
"""

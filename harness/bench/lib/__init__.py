"""The measurement library: what the measurement programs (:mod:`sphrom.bench`) share, and what the validation
report (:mod:`sphrom.report`) and the tests measure with.

Nothing here is a program, and nothing here imports one.  ``timing`` (medians on a noisy machine), ``tables``
(CSV), ``document`` (BENCHMARKS.md as sections replaced in place), ``methods`` (run time against error of every
method), ``scaling``, ``skip``, ``input_direction`` (the tables of ``sphrom bench``), ``sph_scaling`` (the full
SPH step against N and its section), ``fmu`` (the FMU's timings: the C core, end to end, the FMU rows) and
``fmu_sections`` (their Markdown), ``stress``, ``stress_fmu``, ``stress_maps`` (the stability maps and their
Markdown), ``stress_settings`` (their grid), ``ports`` (the port forces and lumped component the port programs
share), ``responses`` (a reduced model under inputs held over communication steps: the input programs' and
tests' run), ``linear_scenes`` (the scenes of the linear-model programs).
"""

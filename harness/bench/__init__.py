"""Benchmarks and stress maps: everything that measures, for commands of their own (never the test suite).

``suite`` runs what ``sphrom bench`` reports (``methods``, ``scaling``, ``skip``,
``input_direction``, ``sph_scaling``, ``fmu``), ``stress_maps`` the maps of
``sphrom stress`` (``stress``, ``stress_fmu``); ``report`` writes their Markdown
(BENCHMARKS.md, stress.md); ``timing`` and ``tables`` are the shared medians and
CSV files.  ``fmu_verify`` (``python -m harness.bench.fmu_verify``) writes the
section of BENCHMARKS.md on the packaged FMU against the full SPH, every scene;
``sph_stencil`` (``python -m harness.bench.sph_stencil``, with its worker
``sph_step_worker``) the section on the numba full SPH step against the C
stencil and an older checkout.
"""

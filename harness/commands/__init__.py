"""The ``sphrom`` subcommands, one module each (``bench`` also adds the commands that are aliases of measurement
programs: ``bench-sph``, ``bench-fmu``, ``stress``).

Each module has ``add_parser(subparsers)`` and ``run(args) -> int``; heavy
imports happen inside ``run`` so that ``sphrom --help`` stays fast.
"""

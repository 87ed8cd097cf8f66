"""The ``sphrom`` subcommands, one module each.

Each module has ``add_parser(subparsers)`` and ``run(args) -> int``; heavy
imports happen inside ``run`` so that ``sphrom --help`` stays fast.
"""

"""The argument parser of every sphrom command and measurement program: one-line errors, exit status 2."""

from __future__ import annotations

import argparse


class Parser(argparse.ArgumentParser):
    """An ArgumentParser (and, through ``add_subparsers``, its subcommands' parsers) whose errors are one line:
    ``sphrom COMMAND: error: OPTION: what is allowed`` (the option's name), exit status 2, no usage block."""

    def error(self, message):
        if message.startswith("argument "):        # "argument --probes: ..." -> "--probes: ..."
            message = message[len("argument "):]
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}\n")

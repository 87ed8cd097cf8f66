"""The argument parser of every sphrom command and measurement program: one-line errors, exit status 2."""

from __future__ import annotations

import argparse
import re


class Parser(argparse.ArgumentParser):
    """An ArgumentParser (and, through ``add_subparsers``, its subcommands' parsers) whose errors are one line:
    ``sphrom COMMAND: error: OPTION: what is allowed`` (the option's name), exit status 2, no usage block.

    A value that reads as a negative number is a value, in every form float() reads: argparse's own test takes
    only ``-1`` and ``-0.001``, so ``--initial-state-scale -1e-3`` (or ``-inf``) was "expected one argument"."""

    # argparse's pattern (an instance attribute) widened to exponents, inf and nan; no sphrom option looks so
    NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = self.NEGATIVE_NUMBER

    def error(self, message):
        if message.startswith("argument "):        # "argument --probes: ..." -> "--probes: ..."
            message = message[len("argument "):]
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}\n")


def fmu_models(text):
    """An option's value that lists models with an FMU, comma-separated (argparse names the option in its error)."""
    from .rom.registry import fmu_model_names
    models = [m for m in str(text).split(",") if m]
    bad = [m for m in models if m not in fmu_model_names()] or ([] if models else [text])
    if bad:
        raise argparse.ArgumentTypeError(f"{bad[0]!r} is not a model with an FMU (allowed: "
                                         f"{', '.join(fmu_model_names())})")
    return models


def positive_int(text):
    """An option's value that must be an integer >= 1 (argparse names the option in its one-line error)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: an integer >= 1)")
    return value

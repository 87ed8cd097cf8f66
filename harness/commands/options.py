"""argparse types that reject bad values with the option's allowed range."""

import argparse
import math


def positive_float(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (allowed: a number > 0)") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: a number > 0)")
    return value


def nonneg_float(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (allowed: a number >= 0)") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text!r} is out of range (allowed: a number >= 0)")
    return value


def int_at_least(lo):
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer (allowed: an integer >= {lo})") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"{value} is out of range (allowed: an integer >= {lo})")
        return value
    return parse


def float_list(text, lo=None):
    """``0,0.4,0.8`` -> [0.0, 0.4, 0.8] (finite numbers, >= lo when given)."""
    try:
        values = [float(p) for p in text.split(",") if p.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of numbers") from None
    if not values or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: allowed: a non-empty list of finite numbers")
    if lo is not None and min(values) < lo:
        raise argparse.ArgumentTypeError(f"{text!r}: values must be >= {lo}")
    return values

"""Argument types for the ``mona-swarm`` subcommands: numbers with a range and a clear message."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def bounded(kind: type, low: float, high: float = math.inf,
            unit: str = '') -> Callable[[str], float]:
    """An argparse ``type`` that parses ``kind`` (int or float) and checks low <= value <= high."""
    noun = 'a whole number' if kind is int else 'a number'
    suffix = f' {unit}' if unit else ''
    allowed = f'[{low:g}, {high:g}]' if math.isfinite(high) else f'[{low:g}, inf)'

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'{text!r} is not {noun}') from None
        if not (low <= value <= high) or (kind is float and not math.isfinite(value)):
            raise argparse.ArgumentTypeError(
                f'{value:g}{suffix} is out of range: allowed {allowed}')
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse

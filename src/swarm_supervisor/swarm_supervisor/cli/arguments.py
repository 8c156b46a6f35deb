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


#: The slowest speed a CLI --speed takes, in cm/s: anything below is far more likely m/s
#: (the YAML's and the study's unit) typed by habit, e.g. 0.08 for 8 cm/s.
MIN_CLI_SPEED = 0.5
_speed_range = bounded(float, 0, 100, 'cm/s')


def speed_cm_s(text: str) -> float:
    """An argparse ``type`` for a CLI ``--speed``: cm/s in [0.5, 100] (every command's
    --speed is in cm/s; the YAML's controller.speed is in m/s)."""
    value = _speed_range(text)
    if value < MIN_CLI_SPEED:
        raise argparse.ArgumentTypeError(
            f'{value:g} cm/s looks like m/s: give cm/s, e.g. --speed {value * 100:g} '
            f'(allowed [{MIN_CLI_SPEED:g}, 100] cm/s)' if value > 0 else
            f'{value:g} cm/s: the robots would not move; give cm/s, e.g. --speed 8 '
            f'(allowed [{MIN_CLI_SPEED:g}, 100] cm/s)')
    return value


speed_cm_s.__name__ = 'float'  # argparse names the type in its messages

"""Argument types for the ``mona-swarm`` subcommands (numbers with a range and a clear message),
and old option names kept as deprecated aliases (one name per concept across commands)."""

from __future__ import annotations

import argparse
import math
import sys
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
    return _not_m_per_s(_speed_range(text))


def speed_cm_s_unbounded(text: str) -> float:
    """:func:`speed_cm_s` without its top: a larger speed is left to the parameter schema,
    which names the key and the range (``launch``, whose -p overrides it checks alike)."""
    return _not_m_per_s(bounded(float, 0, unit='cm/s')(text))


def _not_m_per_s(value: float) -> float:
    """Refuse a CLI speed below :data:`MIN_CLI_SPEED` cm/s: m/s typed by habit, or 0."""
    if value < MIN_CLI_SPEED:
        raise argparse.ArgumentTypeError(
            f'{value:g} cm/s looks like m/s: give cm/s, e.g. --speed {value * 100:g} '
            f'(allowed [{MIN_CLI_SPEED:g}, 100] cm/s)' if value > 0 else
            f'{value:g} cm/s: the robots would not move; give cm/s, e.g. --speed 8 '
            f'(allowed [{MIN_CLI_SPEED:g}, 100] cm/s)')
    return value


speed_cm_s.__name__ = speed_cm_s_unbounded.__name__ = 'float'  # argparse names the type


class _Deprecated(argparse.Action):
    """An old option name that still works: it sets the new option's value and says, once
    per use on stderr, which name to use instead."""

    def __init__(self, option_strings, dest, new: str, **kwargs) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        print(f'{parser.prog}: warning: {option_string} is deprecated and will be removed: '
              f'use {self.new}', file=sys.stderr)
        setattr(namespace, self.dest, values)


def deprecated_alias(parser: argparse.ArgumentParser, old: str, new: str) -> None:
    """Accept ``old`` as a deprecated spelling of the option ``new`` (added already): the same
    value, type and checks, hidden from --help, with a warning when used."""
    action = next(a for a in parser._actions if new in a.option_strings)
    # argparse takes type=None (no conversion), which typeshed's stub does not say
    parser.add_argument(old, dest=action.dest, type=action.type,  # type: ignore[arg-type]
                        metavar=action.metavar, action=_Deprecated, new=new,
                        help=argparse.SUPPRESS)

"""A user's own code, met with one line instead of a traceback: a module imported by name (the
metric modules named in ``MONA_SWARM_METRICS``, :mod:`swarm_metrics.metrics`, and any other
plug-in a command loads), and the value each metric's ``compute`` returns.

A module that cannot be found, or raises while it is imported (a syntax error, a name it
lacks, its own exception), stops the command before any work with the module's name, where
it was named, the error and the user's line. A metric that raises, or returns anything but
one number (an array, None), is named with what it did.
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np

from mona_controller.schema import ParameterError


def import_plugin(module: str, named_by: str) -> Any:
    """Import a user's module (one that registers metrics, say), or refuse it in one line.

    Args:
        module: its dotted name.
        named_by: where it was named, for the message (e.g. the environment variable).

    Raises:
        ParameterError: it cannot be found, or importing it raised (a syntax error, a name
            it lacks, ...): naming the module, where it was named, the error and its line.
    """
    try:
        return importlib.import_module(module)
    except Exception as error:  # the user's code may raise anything on import
        where = ''  # the deepest line of the user's code (a syntax error names its own)
        trace = None if isinstance(error, SyntaxError) else error.__traceback__
        while trace is not None:
            file = trace.tb_frame.f_code.co_filename
            if not file.startswith('<frozen') and file not in (__file__, importlib.__file__):
                where = f' ({file}, line {trace.tb_lineno})'
            trace = trace.tb_next
        hint = ('install it, or put its folder on PYTHONPATH' if isinstance(
            error, ModuleNotFoundError) and error.name == module.split('.')[0] else
            'fix it, or leave it out')
        raise ParameterError(f'{named_by} names {module!r}, which cannot be imported: '
                             f'{type(error).__name__}: {error}{where}; {hint}') from None


class MetricError(ParameterError):
    """A metric's ``compute`` raised, or returned something other than one number."""


def measure(metric: Any, inputs: Any) -> float:
    """``metric.compute(inputs)`` as the float of a metrics row.

    Raises:
        MetricError: naming the metric and what it raised or returned (an array, None, text).
    """
    try:
        value = metric.compute(inputs)
    except Exception as error:  # a user's metric: name it, not a traceback
        raise MetricError(f'metric {metric.name!r} raised {type(error).__name__}: {error}'
                          f'{_where(error)}: fix its compute') from None
    try:
        if np.ndim(value) == 0:
            return float(value)
    except (TypeError, ValueError):
        pass
    shape = np.shape(value) if isinstance(value, (np.ndarray, list, tuple)) else None
    what = f'an array of shape {shape}' if shape is not None else repr(value)[:40]
    raise MetricError(f'metric {metric.name!r} returned {what}, not one number: its compute '
                      'must return a float per sample (e.g. float(np.mean(...)))')


def _where(error: Exception) -> str:
    """' (file, line N)' of the deepest frame of an exception, or ''."""
    trace = error.__traceback__
    while trace is not None and trace.tb_next is not None:
        trace = trace.tb_next
    return '' if trace is None else \
        f' ({trace.tb_frame.f_code.co_filename}, line {trace.tb_lineno})'

"""A user's metric, met with one line instead of a traceback: the value each metric's
``compute`` returns. A metric that raises, or returns anything but one number (an array,
None), is named with what it did (a plug-in that does not import is
:mod:`mona_controller.plugins`' to refuse).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mona_controller.schema import ParameterError


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

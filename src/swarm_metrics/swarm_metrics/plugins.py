"""A user's own module, imported by name, or refused in one line: the metric modules named in
``MONA_SWARM_METRICS`` (:mod:`swarm_metrics.metrics`) and any other plug-in a command loads.

A module that cannot be found, or raises while it is imported (a syntax error, a name it
lacks, its own exception), stops the command before any work with the module's name, where
it was named, the error and the user's line, never a traceback.
"""

from __future__ import annotations

import importlib
from typing import Any

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

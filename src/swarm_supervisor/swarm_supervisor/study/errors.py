"""The study's errors (each a one-line message on the command line)."""

from __future__ import annotations

from mona_controller.schema import ParameterError


class StudyError(ParameterError):
    """The study's folder or episodes do not fit the requested design (exit status 2)."""


class EpisodeFailed(RuntimeError):
    """An episode raised in a worker; the message names it and holds the worker's traceback."""

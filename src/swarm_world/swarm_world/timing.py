"""Sim-time arithmetic on integer nanoseconds, written once for every package.

Sim time advances in whole steps of ``step_ns``; periodic work (cleaning ticks, metrics
samples, cue maps, status) happens at the first step that reaches or passes a multiple of its
period. Pure: the world, the runners, the nodes and bag analysis all count the same way.
"""

from __future__ import annotations


def crossed(before_ns: int, after_ns: int, period_ns: int) -> bool:
    """Whether ``(before_ns, after_ns]`` holds a multiple of ``period_ns`` (period 0: always).

    A boundary exactly at ``after_ns`` counts, one exactly at ``before_ns`` does not, so each
    boundary is seen once by consecutive steps; several boundaries in one step count once.
    """
    return period_ns == 0 or after_ns // period_ns > before_ns // period_ns


def steps_for(duration_s: float, step_ns: int) -> int:
    """Steps in an episode of ``duration_s`` seconds: the duration rounded up to whole steps.

    The duration is rounded to whole nanoseconds, then divided exactly in integers: 0.07 s of
    10 ms steps is 7 steps (0.07 / 0.01 in floats is 7.000000000000001, which would make 8).
    """
    return -(-round(duration_s * 1e9) // step_ns)

"""Run the rules (test_interfaces.py) in a pytest of their own, as the self-tests do."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: The rules that hold the probe's record of every robot's readings to every step. The world's
#: readings writers keep the last 5 (the page's QoS); a probe held off the CPU long enough on
#: a loaded machine misses a few steps' readings that the world did publish (seen twice in
#: about ten runs under ../shared/tools/under-load: 4 consecutive steps of one robot, in a
#: run whose every other rule passed). The rules that want a status and a cue map in every
#: period are held to samples the world keeps only the last of (transient local, depth 1):
#: the same stall loses them (ci27: readings of 2.05-2.37 s and the cue map of 2.05 s, in one
#: stall). Only when these alone fail is a run tried again.
READINGS_RULES = frozenset({'test_lockstep_readings_are_stamped_start_ns_plus_k_step_ns',
                            'test_ground_and_proximity_have_the_same_stamp',
                            'test_cue_map_and_markers_every_map_period',
                            'test_status_each_status_period_while_running'})


def run_rules(*args: str, timeout: float) -> subprocess.CompletedProcess:
    """The rules against what ``args`` name (``--world-cmd``, ``--params``...), quietly, with
    failures listed (-rfE). The outer run's PYTEST_ADDOPTS is not passed on: a
    ``--junitxml`` there would have the inner run overwrite the outer run's report."""
    env = {key: value for key, value in os.environ.items() if key != 'PYTEST_ADDOPTS'}
    command = [sys.executable, '-m', 'pytest', str(HERE / 'test_interfaces.py'), '-q', '-rfE',
               '-p', 'no:cacheprovider', *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                          cwd=HERE.parents[1], env=env)


def failed_rules(stdout: str) -> set[str]:
    """The rules a run's -rfE summary lists as failed or in error (parameters dropped)."""
    return set(re.findall(r'^(?:FAILED|ERROR) \S*test_interfaces\.py::(\w+)', stdout,
                          re.MULTILINE))


def run_rules_once_more(*args: str, timeout: float, after_any_failure: bool = False
                        ) -> tuple[str, subprocess.CompletedProcess]:
    """:func:`run_rules`, and once more when only :data:`READINGS_RULES` failed (or, with
    ``after_any_failure``, when anything did); (what the first run printed when there was a
    second, the last run)."""
    result = run_rules(*args, timeout=timeout)
    failed = failed_rules(result.stdout)
    if result.returncode == 0 or not (after_any_failure or failed and failed <= READINGS_RULES):
        return '', result
    first = f'first run (failed: {sorted(failed)}):\n{result.stdout[-3000:]}\nsecond run:\n'
    print(first)
    return first, run_rules(*args, timeout=timeout)

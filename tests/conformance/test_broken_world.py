"""The suite's self-test: run against a deliberately broken world (the world node behind a
relay that reverses the beam order, broken/reversed_beams.py), the suite must fail, and fail
the rule that is broken."""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

from implementations import IMPLEMENTATIONS
from inner_suite import READINGS_RULES, run_rules

pytestmark = [pytest.mark.ros, pytest.mark.selftest]

HERE = Path(__file__).resolve().parent
#: The rules a reversed beam order may break: the order itself, and what is compared beam by
#: beam with the geometry.
BEAM_RULES = {'test_beams_run_right_to_left',
              'test_ranges_are_measured_from_the_body_edge_inf_beyond_range_max',
              'test_intensities_are_1_for_a_robot_and_0_otherwise'}


def test_a_world_with_the_beams_reversed_fails_the_beam_order_rule(tmp_path):
    world = IMPLEMENTATIONS['world'].command
    command = f'{sys.executable} {HERE / "broken" / "reversed_beams.py"} ' \
              f'--population {{population}} -- {world}'
    report = tmp_path / 'report.xml'
    result, failed, outcomes = run_against(command, report)
    first = ''
    if failed - BEAM_RULES and failed - BEAM_RULES <= READINGS_RULES:
        # The probe lost samples on a loaded machine (inner_suite.READINGS_RULES;
        # the relay, a Python hop keeping the last 5, can fall behind too): once more.
        first = f'first run failed {sorted(failed)}:\n{result.stdout[-3000:]}\nsecond run:\n'
        print(first)
        result, failed, outcomes = run_against(command, report)
    assert result.returncode == 1, first + result.stdout[-3000:]  # failed (not an error)
    assert 'test_beams_run_right_to_left' in failed, first + result.stdout[-3000:]
    assert failed <= BEAM_RULES, (failed - BEAM_RULES, first + result.stdout[-6000:])
    # Everything the relay does not touch still conforms.
    assert len(outcomes) - len(failed) >= 20


def run_against(command: str, report: Path):
    """The rules against ``command``: (the run, the rules that failed, rule -> failed)."""
    result = run_rules('--world-cmd', command, f'--junitxml={report}', timeout=300)
    outcomes: dict[str, bool] = {}
    if report.exists():
        for case in ElementTree.parse(report).getroot().iter('testcase'):
            name = case.get('name').split('[')[0]
            bad = case.find('failure') is not None or case.find('error') is not None
            outcomes[name] = outcomes.get(name, False) or bad
    return result, {name for name, bad in outcomes.items() if bad}, outcomes

"""The golden digests of tests/golden/digests.json: today's numbers are the recorded ones."""

import pytest

import golden


@pytest.fixture(scope='module')
def recorded() -> dict:
    return golden.load()


def test_the_libraries_are_those_the_digests_were_recorded_with(recorded):
    assert golden.library_versions() == recorded['libraries'], (
        'the digests were recorded with other library versions: install requirements.txt, or '
        'rerun tests/golden/golden.py --write in a commit that says why the numbers moved')


@pytest.mark.parametrize('case', sorted(golden.CASES))
def test_outputs_equal_the_golden_digests(case, recorded):
    lines = golden.differences(recorded['cases'][case], golden.case_digests(case))
    assert not lines, f'{case} moved:\n' + '\n'.join(lines)


def test_a_changed_number_changes_a_digest():
    """The digests see a change in the last bit of one metric."""
    [result] = golden.run_case('default')
    before = golden.episode_digests(result)
    row = result.metrics[-1]
    row['coherency'] = float(__import__('numpy').nextafter(row['coherency'], 10.0))
    after = golden.episode_digests(result)
    assert golden.differences([before], [after]) == [
        f'episode 0: metrics.csv: {before["metrics.csv"]} -> {after["metrics.csv"]}']

"""docs/reproduction.md against the files it quotes.

Every number the report takes from a file the repository ships is worked out here from that
file, written as the report writes it, and must appear in the report verbatim; a number
that is still to come is listed in :data:`PENDING` and in the report's one table "Numbers
pending", and nowhere else pretends to be a result.

To quote another number, add an entry to :data:`QUOTES`: a name and a function that returns
the text the report must contain, built from the shipped file. When a pending number lands,
write it into the report, delete its row from "Numbers pending" and its id from
:data:`PENDING`, and give it a :data:`QUOTES` entry that reads it from its file.
"""

from __future__ import annotations

import functools
import json
import re
from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest

from swarm_supervisor.analysis.claims import paper_claims
from swarm_supervisor.analysis.speed_effect import PAPER_RATIO, regime_table
from swarm_supervisor.evolution.heldout import load_plan

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / 'docs' / 'reproduction.md'
#: What `make run` (the paper's study) made, as shipped: its report.md, ANOVA tables, figures.
STUDY = ROOT / 'docs' / 'media' / 'paper_study'
#: What `mona-swarm heldout` made of the cooperation comparison (docs/learned.md), as shipped.
HELDOUT = ROOT / 'docs' / 'media' / 'learned' / 'heldout'
#: Its plan, which names the scenarios, N, the duration and the seeds.
PLAN = ROOT / 'ros_ws' / 'config' / 'designs' / 'learned_heldout.yaml'
#: What the existence search made (calibration.md, trials.csv, the confirmed studies), as shipped.
EXISTENCE = ROOT / 'docs' / 'media' / 'existence'
#: The claims a swarm that gathers and cleans shows: where none of them holds, it does neither.
GATHERS_AND_CLEANS = ('fig4-halved-by-1500s', 'fig5-rises-then-settles')
#: The scenarios of eq. 3's cleaning the report quotes, and how it names them.
EQ3 = {'paper': "the paper's arena", 'leaks': 'the moving leaks'}
#: The numbers the report will quote once the work they come from lands; each is a row of
#: the report's table "Numbers pending". None now: the cooperation comparison's C1 to C5
#: landed and are quoted below.
PENDING: tuple[str, ...] = ()


@functools.cache
def doc() -> str:
    """The report as one line of words: a quote may wrap anywhere."""
    return ' '.join(DOC.read_text().split())


def sections() -> tuple[str, str]:
    """The report's text before its table "Numbers pending", and that section."""
    before, rest = DOC.read_text().split('\n## Numbers pending\n', 1)
    return before, rest.split('\n## ', 1)[0]


@functools.cache
def study_claims() -> dict[str, tuple[str, str]]:
    """The paper study's "Compared with the paper" table: claim id -> (ours, verdict)."""
    claims = {}
    for line in (STUDY / 'report.md').read_text().splitlines():
        cells = [cell.strip() for cell in line.strip('|').split('|')]
        if len(cells) == 5 and cells[0].startswith('`') and cells[0].endswith('`'):
            claims[cells[0].strip('`')] = (cells[3], cells[4].strip('*'))
    return claims


@functools.cache
def study_report() -> str:
    return (STUDY / 'report.md').read_text()


def anova_ratio(name: str) -> float:
    frame = pd.read_csv(STUDY / name).set_index('factor')
    return float(frame.loc['speed', 'sum_sq'] / frame.loc['population', 'sum_sq'])


def anova_f(name: str, factor: str) -> float:
    return float(pd.read_csv(STUDY / name).set_index('factor').loc[factor, 'F'])


def speed_line() -> re.Match:
    """report.md's speed-effect sentence, its numbers as groups."""
    match = re.search(r'SS_speed / SS_population of the mean cue is ([\d.]+) \(the paper: '
                      r'([\d.]+)\); by the main effects, N = 50 at 4 cm/s performs like '
                      r'N = ([\d.]+) at 8 cm/s, where the paper\'s ratio would need '
                      r'N = ([\d.]+) with this study\'s population effects \(N = ([\d.]+) '
                      r'with effects linear in N', study_report())
    assert match, 'report.md has no speed-effect sentence'
    return match


@functools.cache
def heldout() -> dict:
    """The comparison's summary.json: scenario -> controllers' scores and paired tests."""
    return json.loads((HELDOUT / 'summary.json').read_text())


def solo_against_beeclust(scenario: str, score: str) -> dict:
    return heldout()[scenario]['pairs']['solitary vs beeclust'][score]


def the_same(values: list) -> object:
    """The one value every entry has: the report writes it once for all."""
    assert len(set(values)) == 1, values
    return values[0]


def cue_left(scenario: str) -> str:
    controllers = heldout()[scenario]['controllers']
    return (f'{EQ3[scenario]} BEECLUST {controllers["beeclust"]["final_mean"]:.3f}, the '
            f'solitary rule {controllers["solitary"]["final_mean"]:.3f}')


def eq3_tests() -> list[dict]:
    return [solo_against_beeclust(scenario, score) for scenario in EQ3
            for score in ('final', 'fitness')]


def eq3_common(key: str, spec: str = '') -> str:
    """``key`` of the solitary rule's tests against BEECLUST under eq. 3 (both scenarios,
    both scores), formatted by ``spec``: one text for all four, as the report gives it."""
    return str(the_same([format(test[key], spec) for test in eq3_tests()]))


def heldout_tests() -> int:
    """How many tests the comparison's Holm family holds."""
    return sum(len(tests) for entry in heldout().values() for tests in entry['pairs'].values())


@functools.cache
def trials() -> pd.DataFrame:
    """The existence search's screened trials, with the set of claims each held."""
    frame = pd.read_csv(EXISTENCE / 'trials.csv')
    every = {claim.id for claim in paper_claims()}
    frame['held'] = [every - set(str(failed).split()) if isinstance(failed, str) else every
                     for failed in frame['failed']]
    return frame


def held_in(claim: str) -> int:
    return sum(claim in held for held in trials()['held'])


def confirmed_claims(trial: int) -> dict[str, str]:
    """A confirmed trial's study: claim id -> verdict."""
    report = (EXISTENCE / 'confirm' / f'trial_{trial:04d}' / 'report.md').read_text()
    rows = [[cell.strip() for cell in line.strip('|').split('|')]
            for line in report.splitlines()]
    return {cells[0].strip('`'): cells[4].strip('*') for cells in rows
            if len(cells) == 5 and cells[0].startswith('`')}


def confirmed_f(trial: int, factor: str) -> float:
    frame = pd.read_csv(EXISTENCE / 'confirm' / f'trial_{trial:04d}' / 'anova_cue.csv')
    return float(frame.set_index('factor').loc[factor, 'F'])


def confirmed_ratio(trial: int) -> float:
    frame = pd.read_csv(EXISTENCE / 'confirm' / f'trial_{trial:04d}' / 'anova_cue.csv')
    frame = frame.set_index('factor')
    return float(frame.loc['speed', 'sum_sq'] / frame.loc['population', 'sum_sq'])


def order_screened() -> str:
    """The screened trials that held table 2's order: how many, the first and its claims."""
    holding = trials()[[('table2-factor-order' in held) for held in trials()['held']]]
    first = holding.iloc[0]
    return (f'held in {len(holding)} screened trial (trial {int(first["trial"])}, '
            f'{len(first["held"])} of 13 claims)')


def nearest_trial() -> str:
    """The screened trial whose SS_speed / SS_population is nearest the paper's."""
    nearest = trials().loc[(trials()['ratio'] - PAPER_RATIO).abs().idxmin()]
    return (f'(trial {int(nearest["trial"])}, {nearest["ratio"]:.3f}) held '
            f'{int(nearest["claims_held"])} claims')


def _claim_row(claim_id: str) -> Callable[[], str]:
    def text() -> str:
        ours, verdict = study_claims()[claim_id]
        return f'| {ours} | {verdict} |'
    return text


#: Each quoted number: a name, and the text the report must contain, built from its file.
QUOTES: dict[str, Callable[[], str]] = {
    **{f'paper study: {claim.id}': _claim_row(claim.id) for claim in paper_claims()},
    'paper study: claims held': lambda: (
        f'{sum(v == "holds" for _, v in study_claims().values())} of '
        f'{len(study_claims())} claims hold'),
    'paper study: ratio': lambda: f'SS_speed / SS_population = {anova_ratio("anova_cue.csv"):.3f}',
    'paper study: F of the mean cue': lambda: (
        f'F = {anova_f("anova_cue.csv", "speed"):.0f} for speed, '
        f'{anova_f("anova_cue.csv", "population"):.0f} for population and '
        f'{anova_f("anova_cue.csv", "time"):.0f} for time'),
    'paper study: N = 50 at 4 cm/s performs like': lambda: (
        f'N = 50 at 4 cm/s performs like N = {speed_line()[3]} at 8 cm/s'),
    'paper study: what the paper needs': lambda: (
        f'N = {speed_line()[4]} with our population effects, N = {speed_line()[5]} with '
        'effects linear in N'),
    'paper ratio': lambda: f'{PAPER_RATIO:.3f}',
    **{f'regime {i}': functools.partial(lambda i: regime_table()[i], i)
       for i in range(len(regime_table()))},
    'cooperation: the plan': lambda: (
        f'N = {load_plan(PLAN).robots}, {load_plan(PLAN).duration:g} s, on '
        f'{len(load_plan(PLAN).seeds)} held-out seeds'),
    **{f'cooperation: cue left, {scenario}': functools.partial(cue_left, scenario)
       for scenario in EQ3},
    'cooperation: fitness': lambda: ', '.join(
        ' and '.join(f'{heldout()[s]["controllers"][c]["fitness_mean"]:.3f}'
                     for c in ('beeclust', 'solitary')) for s in EQ3),
    'cooperation: seeds': lambda: (
        f'the solitary rule leaves less: {eq3_common("a_lower")} of {eq3_common("seeds")} '
        'on both'),
    'existence: trials': lambda: f'It ran {len(trials())} trials of its screening study',
    'existence: sparse coherency': lambda: (
        f'(`fig6-sparse-unchanged`) held in {held_in("fig6-sparse-unchanged")} of '
        f'{len(trials())} trials'),
    'existence: sparse ratio': lambda: (
        f'(`fig5-sparse-unchanged`) held in {held_in("fig5-sparse-unchanged")} of '
        f'{len(trials())} trials'),
    'existence: order, screened': lambda: order_screened(),
    'existence: trial 29': lambda: (
        f'it holds {sum(v == "holds" for v in confirmed_claims(29).values())} of 13 claims, '
        f"speed's F = {confirmed_f(29, 'speed'):.1f} just above population's F = "
        f'{confirmed_f(29, "population"):.1f}, SS_speed / SS_population = '
        f'{confirmed_ratio(29):.3f}'),
    'existence: ratios': lambda: (
        f'ran from {trials()["ratio"].min():.3g} to {trials()["ratio"].max():.3g} over the '
        'screened trials'),
    'existence: nearest': lambda: nearest_trial(),
    'existence: most held': lambda: (
        f'The most any trial held is {trials()["claims_held"].max()} of 13'),
    'cooperation: p': lambda: (
        f'p = {eq3_common("p_value", ".2g")} for each, {eq3_common("p_holm", ".2g")} '
        f"after Holm's adjustment over the comparison's {heldout_tests()} tests"),
}


@pytest.mark.parametrize('name', sorted(QUOTES))
def test_every_quoted_number_is_the_shipped_files(name):
    text = ' '.join(QUOTES[name]().split())
    assert text in doc(), f'{name}: docs/reproduction.md does not say {text!r}'


def test_the_study_shipped_is_the_papers_whole_design():
    assert set(study_claims()) == {claim.id for claim in paper_claims()}
    assert 'from 60 episodes' in study_report()
    for name in ('fig3_cue_maps.png', 'fig4_mean_cue.png', 'fig5_ratio_near_source.png',
                 'fig6_coherency.png'):
        assert f'(media/paper_study/{name})' in doc(), name


def test_pending_numbers_are_listed_in_one_place_and_nowhere_pretend():
    before, pending = sections()
    rows = [[cell.strip() for cell in line.strip().strip('|').split('|')]
            for line in pending.splitlines() if re.match(r'\|\s*C\d+\s*\|', line)]
    assert [row[0] for row in rows] == list(PENDING)
    assert all(row[-1] == '**pending**' for row in rows), rows
    # The text cites each pending number by its id, and writes "pending" as a value nowhere
    # else.
    for number in PENDING:
        assert f'[{number}](#numbers-pending)' in before, number
    assert '**pending**' not in before


def test_the_reports_unreached_claims_are_the_existence_searchs():
    """report.md's one line (``UNREACHED``, ``ONLY_WITHOUT_CLEANING``) says what the shipped
    search found: an unreached claim held in no trial, screened or confirmed; the others held
    only where the swarm neither halved the cue by 1500 s nor gathered at the source."""
    from swarm_supervisor.analysis.report import ONLY_WITHOUT_CLEANING, UNREACHED
    confirmed = [confirmed_claims(int(folder.name.split('_')[1]))
                 for folder in sorted((EXISTENCE / 'confirm').glob('trial_*'))]
    assert confirmed
    helds = [*trials()['held'], *({c for c, v in row.items() if v == 'holds'}
                                  for row in confirmed)]
    for claim in UNREACHED:
        assert not any(claim in held for held in helds), claim
    for claim in ONLY_WITHOUT_CLEANING:
        with_it = [held for held in helds if claim in held]
        assert with_it, f'{claim} held nowhere: it belongs in UNREACHED'
        assert not any(set(GATHERS_AND_CLEANS) & held for held in with_it), claim
    # Every claim the search never reached is named.
    every = {claim.id for claim in paper_claims()}
    assert {c for c in every if not any(c in held for held in helds)} == set(UNREACHED)

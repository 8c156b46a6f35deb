"""After the search: the best candidates confirmed on the full study, the trials as a table,
calibration.md, and the best profile as a parameter file of its own."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
import yaml

from mona_controller.mappings import unflatten
from swarm_supervisor import study
from swarm_supervisor.analysis.claims import Claim, paper_claims
from swarm_supervisor.analysis.report import analyse, markdown_table
from swarm_supervisor.calibration.design import CalibrationDesign
from swarm_supervisor.calibration.objective import score
from swarm_supervisor.calibration.search import TrialResult
from swarm_supervisor.study.workers import START_METHOD

TRIALS_CSV = 'trials.csv'
CONFIRM_DIR = 'confirm'
REPORT_FILE = 'calibration.md'
PROFILE_FILE = 'best_profile.yaml'
#: An existence search's best trial: a parameter file too, but not a profile to run with.
BEST_TRIAL_FILE = 'best_trial.yaml'


def best_file(design: CalibrationDesign) -> str:
    """The name of the parameter file holding the best trial's values."""
    return BEST_TRIAL_FILE if design.purpose == 'existence' else PROFILE_FILE


def candidates(results: Sequence[TrialResult], count: int) -> list[TrialResult]:
    """The ``count`` best screened trials (lowest loss; the earlier trial on a tie)."""
    return sorted(results, key=lambda r: (r.score.loss, r.number))[:count]


def confirm(design: CalibrationDesign, out: Path, chosen: Sequence[TrialResult],
            claims: Sequence[Claim], *, jobs: int | None = None, scheduler: str | None = None,
            scheduler_timeout: float = 30.0, start_method: str = START_METHOD
            ) -> list[TrialResult]:
    """Run each chosen trial on the full study into ``out/confirm/trial_<n>`` (a study folder
    with its own report.md; resumable) and score it there."""
    confirmed = []
    for result in chosen:
        config = design.trial_config(result.values, design.confirm_study)
        folder = out / CONFIRM_DIR / f'trial_{result.number:04d}'
        rows = study.run_study(config, folder, jobs=jobs, scheduler=scheduler,
                               scheduler_timeout=scheduler_timeout, start_method=start_method)
        table = pd.DataFrame(rows)
        analyse(folder, [folder / study.EPISODES_DIR / spec.name
                         for spec in study.design(config)],
                table=table, parameters_file=study.PARAMETERS_FILE)
        confirmed.append(TrialResult(result.number, result.values,
                                     score(table, claims, design.objective)))
    return confirmed


def trials_table(results: Sequence[TrialResult]) -> pd.DataFrame:
    """One row per trial: its number, values and score."""
    return pd.DataFrame([{'trial': r.number, **r.values, **r.score.as_row()} for r in results])


def profile_text(design: CalibrationDesign, best: TrialResult, where: str) -> str:
    """A parameter file setting the best trial's values (every other parameter as the base)."""
    sections = unflatten(best.values)
    held = len(best.score.held)
    verb = ('The best trial of the existence search (not a profile: its ranges were chosen '
            'wide, not defensible) of' if design.purpose == 'existence' else 'Calibrated by')
    header = (f'# {verb} `mona-swarm calibrate {design.path}` (trial {best.number}, '
              f'{where}):\n# {held} of {held + len(best.score.failed)} claims hold, '
              f'SS_speed / SS_population = {best.score.ratio:.3g} '
              f'(target {design.objective.ratio_target:.3g}). Every other parameter is the '
              'schema default.\n')
    return header + yaml.safe_dump({'/**': {'ros__parameters': sections}}, sort_keys=False)


def write_report(design: CalibrationDesign, out: Path, results: Sequence[TrialResult],
                 confirmed: Sequence[TrialResult], started: float) -> Path:
    """trials.csv, the best trial's parameter file (:func:`best_file`) and calibration.md;
    returns the report's path."""
    trials_table(results).to_csv(out / TRIALS_CSV, index=False)
    best, where = ((min(confirmed, key=lambda r: (r.score.loss, r.number)), 'the full study')
                   if confirmed else
                   (min(results, key=lambda r: (r.score.loss, r.number)), 'the screening'))
    best_name = best_file(design)
    (out / best_name).write_text(profile_text(design, best, where))
    existence = design.purpose == 'existence'
    lines = [f'# {"Existence search" if existence else "Calibration"}: {design.path.name}', '']
    if existence:
        lines += ['*An existence search, not a profile: its ranges are deliberately wide, '
                  'defensible or not, to ask whether any model of this family reaches the '
                  "paper's claims. Its best trial is no model to run the study with.*", '']
    lines += [f'{len(results)} trials of the screening study '
             f'({_study_text(design.screen)}), seed {design.seed}, in '
             f"{time.perf_counter() - started:.0f} s. A trial's loss is the number of the "
             "paper's claims that do not hold plus "
             f"{design.objective.ratio_weight:g} per decade between the mean cue's "
             f"SS_speed / SS_population and {design.objective.ratio_target:.3g} (the paper's "
             'table 2). Every trial: [`trials.csv`](trials.csv).', '',
             '## Searched', '']
    for parameter in design.parameters:
        span = (', '.join(map(str, parameter.choices)) if parameter.kind == 'choice'
                else f'{parameter.low:g} .. {parameter.high:g}'
                + (' (log)' if parameter.log else ''))
        lines.append(f'- `{parameter.key}`: {span}')
    lines += ['', '## Each claim: in how many screened trials it held', '',
              markdown_table(claim_tally(results)), '',
              f'SS_speed / SS_population over the trials: {_ratio_span(design, results)}.', '',
              '## The best screened trials', '',
              markdown_table(_shown(trials_table(sorted(results, key=lambda r: (
                  r.score.loss, r.number))[:10]))), '']
    if confirmed:
        lines += [f'## Confirmed on the full study ({_study_text(design.confirm_study)})', '',
                  "Each candidate's study, with its report.md, is in "
                  f'`{CONFIRM_DIR}/trial_<n>/`.', '',
                  markdown_table(_shown(trials_table(confirmed))), '']
    lines += [f'## The best {"trial" if existence else "profile"}', '',
              f'Trial {best.number} on {where}: [`{best_name}`]({best_name}) sets',
              '', *(f'- `{key}`: {value}' for key, value in best.values.items()), '',
              f'Claims that hold ({len(best.score.held)}): '
              + (', '.join(f'`{c}`' for c in best.score.held) or 'none') + '.', '',
              'Claims that do not: ' + (', '.join(f'`{c}`' for c in best.score.failed)
                                        or 'none') + '.', '']
    path = out / REPORT_FILE
    path.write_text('\n'.join(lines))
    return path


def claim_tally(results: Sequence[TrialResult]) -> pd.DataFrame:
    """Per claim (the paper's claims in their file's order, then any other), how many of the
    trials it held in."""
    seen = {name for r in results for name in (*r.score.held, *r.score.failed)}
    paper = [claim.id for claim in paper_claims() if claim.id in seen]
    names = paper + sorted(seen - set(paper))
    return pd.DataFrame([{'claim': f'`{name}`',
                          'held in': sum(name in r.score.held for r in results),
                          'of trials': len(results)} for name in names])


def _ratio_span(design: CalibrationDesign, results: Sequence[TrialResult]) -> str:
    formed = [r for r in results if not math.isnan(r.score.ratio)]
    if not formed:
        return 'never formed'
    target = design.objective.ratio_target
    nearest = min(formed, key=lambda r: (abs(math.log10(r.score.ratio / target)), r.number))
    return (f'{min(r.score.ratio for r in formed):.3g} to '
            f'{max(r.score.ratio for r in formed):.3g}; nearest to {target:.3g}: '
            f'{nearest.score.ratio:.3g} (trial {nearest.number})')


def _shown(frame: pd.DataFrame) -> pd.DataFrame:
    shown = frame.drop(columns=['failed'])
    for column in shown.columns:
        if shown[column].dtype.kind == 'f':
            shown[column] = [_number(v) for v in shown[column]]
    return shown


def _number(value: float) -> str:
    return '-' if math.isnan(value) else f'{value:.4g}'


def _study_text(params) -> str:
    return (f'N = {", ".join(map(str, params.populations))} x '
            f'{", ".join(f"{v * 100:g}" for v in params.speeds)} cm/s x '
            f'{len(params.seeds)} seeds, {params.duration:g} s')

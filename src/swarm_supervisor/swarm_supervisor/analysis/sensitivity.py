"""Which claims hinge on which decision: the claims checked on each cell of a sweep.

For a study with extra factors (``study.factors``), every combination of their levels is a
*variant* (:func:`swarm_supervisor.analysis.figures.variants`). :func:`claim_matrix` checks every
claim on each variant's episodes; in a one-at-a-time design the variant that keeps every
decision at the parameter file's value is the *base*, and a claim *changes* under a level
whose verdict differs from the base's. :func:`write_sensitivity` writes the matrix as
``sensitivity.csv`` and ``sensitivity.md``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from swarm_supervisor.analysis import checks
from swarm_supervisor.analysis import claims as claim_checks
from swarm_supervisor.analysis.figures import BASE_LABEL, variants

MATRIX_CSV = 'sensitivity.csv'
MATRIX_MD = 'sensitivity.md'
#: How each verdict is shown in the Markdown table.
MARKS = {claim_checks.HOLDS: 'holds', claim_checks.FAILS: 'fails',
         claim_checks.NOT_APPLICABLE: 'n/a'}


def claim_matrix(table: pd.DataFrame,
                 claims: Sequence[claim_checks.Claim]) -> pd.DataFrame:
    """One row per variant of the design (column ``variant``), one column per claim id,
    holding the verdict (:data:`~swarm_supervisor.analysis.claims.STATUSES`); the base
    variant first."""
    rows = []
    for label, subset in variants(table):
        results = checks.evaluate(subset, claims)
        rows.append({'variant': label, **{result.id: result.status for result in results}})
    matrix = pd.DataFrame(rows, columns=['variant', *(claim.id for claim in claims)])
    base_first = matrix['variant'].ne(BASE_LABEL)
    return matrix.iloc[base_first.argsort(kind='stable')].reset_index(drop=True)


def changed(matrix: pd.DataFrame) -> pd.DataFrame:
    """Per variant and claim: does the verdict differ from the base's? (all False without a
    base row, as in a crossed design.) Claims not applicable in either are never changed."""
    flags = pd.DataFrame(False, index=matrix.index, columns=matrix.columns[1:])
    base = matrix[matrix['variant'] == BASE_LABEL]
    if base.empty:
        return flags
    reference = base.iloc[0]
    for claim in flags.columns:
        applicable = (matrix[claim] != claim_checks.NOT_APPLICABLE) & \
            (reference[claim] != claim_checks.NOT_APPLICABLE)
        flags[claim] = applicable & (matrix[claim] != reference[claim])
    return flags


def render(matrix: pd.DataFrame, claims: Sequence[claim_checks.Claim]) -> str:
    """The matrix as Markdown: a verdict per variant and claim, **bold** where it differs from
    the base, then the claims' wording and each variant's number of changed verdicts."""
    flags = changed(matrix)
    ids = list(matrix.columns[1:])
    lines = ['| variant | ' + ' | '.join(f'`{claim}`' for claim in ids) + ' | changed |',
             '|---|' + '---|' * (len(ids) + 1)]
    for index, row in matrix.iterrows():
        cells = [f'**{MARKS[row[c]]}**' if flags.loc[index, c] else MARKS[row[c]] for c in ids]
        lines.append(f'| {row["variant"]} | ' + ' | '.join(cells) +
                     f' | {int(flags.loc[index].sum())} |')
    lines += ['', 'Claims:', '']
    lines += [f'- `{claim.id}` ({claim.where}): {claim.paper}' for claim in claims]
    return '\n'.join(lines) + '\n'


def write_sensitivity(out_dir: str | Path, table: pd.DataFrame,
                      claims: Sequence[claim_checks.Claim]) -> Path | None:
    """Write ``sensitivity.csv`` and ``sensitivity.md`` for a design with extra factors.

    Returns:
        The path of sensitivity.md, or None when the design has no extra factor (nothing
        written, and an earlier run's matrix is removed so it cannot be taken for this one's).
    """
    out = Path(out_dir)
    if len(variants(table)) < 2:
        for name in (MATRIX_CSV, MATRIX_MD):
            (out / name).unlink(missing_ok=True)
        return None
    matrix = claim_matrix(table, claims)
    matrix.to_csv(out / MATRIX_CSV, index=False)
    path = out / MATRIX_MD
    base = (f' (verdicts in bold differ from the variant "{BASE_LABEL}")'
            if (matrix['variant'] == BASE_LABEL).any() else '')
    path.write_text('# Sensitivity of the claims\n\nEach claim checked on the episodes of '
                    f'each variant of the design{base}.\n\n' + render(matrix, claims))
    return path

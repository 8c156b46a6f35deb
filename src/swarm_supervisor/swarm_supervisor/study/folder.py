"""Whose folder is ``--out``: a new study, this study to resume, or something to refuse.

The study never mixes two designs in one folder (:func:`claim_study_folder`): a folder
holding a study of another design (its ``parameters.yaml`` differs in a key that reaches the
episodes) or a record of another kind (a run, an episode, a bag:
:func:`swarm_supervisor.outputs.guard.record_in`) is refused, naming the folder, the first
differing key and ``--overwrite``, which replaces the folder whole
(:func:`swarm_supervisor.outputs.guard.claim_output`). An analysis of existing episodes
(``--from-episodes``, :func:`claim_analysis_folder`) may replace an earlier analysis, whose
every file it writes again, but not a study's folder or another record.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from swarm_supervisor.config import DESIGN_KEYS, SwarmConfig, load_config
from swarm_supervisor.outputs.guard import claim_output, record_in
from swarm_supervisor.study.errors import StudyError

PARAMETERS_FILE = 'parameters.yaml'
TIMING_FILE = 'study.json'
EPISODES_DIR = 'episodes'

#: How to say what to do instead, in every refusal.
FIX = 'choose another --out, or pass --overwrite to replace it whole'


def _flat(config: SwarmConfig) -> dict[str, Any]:
    """Every parameter as ``section.key`` -> its JSON value, but those the design sets in
    each episode itself (the file's own run population, seed, speed and duration)."""
    values = json.loads(json.dumps(config.to_dict()))
    return {f'{section}.{key}': value for section, fields in values.items()
            for key, value in fields.items() if f'{section}.{key}' not in DESIGN_KEYS}


def first_difference(stored: SwarmConfig, wanted: SwarmConfig) -> tuple[str, Any, Any] | None:
    """The first key (schema order) whose value differs: (key, stored, wanted), or None;
    the plug-in files first (``plugins``)."""
    before, after = _flat(stored), _flat(wanted)
    before['plugins'], after['plugins'] = ([plugin.path for plugin in config.plugins]
                                           for config in (stored, wanted))
    after = {'plugins': after.pop('plugins'), **after}
    for key in after:
        if before.get(key) != after[key]:
            return key, before.get(key), after[key]
    return None


def is_study(out: Path) -> bool:
    """Whether ``out`` holds a study this command wrote (its parameters, history or
    episodes folder), which a run of the same design resumes."""
    return any((out / name).exists() for name in (PARAMETERS_FILE, TIMING_FILE, EPISODES_DIR))


def claim_study_folder(config: SwarmConfig, out: Path, *, overwrite: bool = False) -> None:
    """Make ``out`` ready for this study: nothing to do for a new folder or one holding this
    design; with ``overwrite``, any record there is deleted whole first.

    Raises:
        StudyError: ``out`` holds a study of another design, or a record that is not a
            study (a run, an episode, a bag), and ``overwrite`` is false.
    """
    if out.exists() and not out.is_dir():
        raise StudyError(f'--out {out} is a file, not a folder: choose another --out')
    if overwrite:
        if is_study(out) or record_in(out) is not None:
            claim_output(out, overwrite=True)
        return
    if not is_study(out):
        found = record_in(out)
        if found is not None:
            what, marker = found
            if what == 'a study':  # its table and report, but no episodes were run there
                what = 'an analysis of other episodes (study --from-episodes)'
            raise StudyError(f'--out {out} holds {what} ({marker}), not a study run there: '
                             f'{FIX}')
        return
    saved = out / PARAMETERS_FILE
    if not saved.is_file():
        return  # an older study without its parameters: each kept episode is still checked
    try:
        stored = load_config(saved)
    except (OSError, ValueError) as error:
        raise StudyError(f'--out {out} holds a study whose {PARAMETERS_FILE} cannot be read '
                         f'({error}): {FIX}') from None
    differs = first_difference(stored, config)
    if differs is not None:
        key, before, after = differs
        raise StudyError(f'--out {out} holds a study of another design: {key} = {before!r} '
                         f'there, {after!r} here; {FIX}')


def claim_analysis_folder(out: Path, sources: Sequence[Path], *, overwrite: bool = False) -> None:
    """Make ``out`` ready for an analysis of the episodes under ``sources``: a new folder or
    an earlier analysis (all_metrics.csv and report.md, nothing run there) is fine; with
    ``overwrite``, any record there is deleted whole first, unless a source lies inside it.

    Raises:
        StudyError: ``out`` holds a study that ran its episodes there, or a run, episode or
            bag, and ``overwrite`` is false; or ``overwrite`` would delete a source.
    """
    if out.exists() and not out.is_dir():
        raise StudyError(f'--out {out} is a file, not a folder: choose another --out')
    if overwrite:
        inside = [source for source in sources
                  if Path(source).resolve().is_relative_to(out.resolve())]
        if inside:
            raise StudyError(f'--overwrite would delete {inside[0]}, which --from-episodes '
                             f'analyses: it is inside --out {out}; choose another --out')
        claim_output(out, overwrite=True)
        return
    found = record_in(out)
    if found is None:
        return
    what, marker = found
    if is_study(out) or what != 'a study':
        held = 'a study run there' if is_study(out) else f'{what} ({marker})'
        raise StudyError(f'--out {out} holds {held}, which an analysis of other episodes '
                         f'would overwrite: {FIX}')

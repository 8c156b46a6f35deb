"""A calibration design: which parameters to search over, in which ranges, on which studies.

A design is a YAML file with one mapping, ``calibrate``::

    calibrate:
      config: ../mona_swarm.yaml   # the parameter file every trial starts from (relative to
                                   # this file; default: the shipped one)
      seed: 1                      # the search's seed: the same seed, the same trials
      trials: 40                   # trials on the screening design
      batch: 2                     # trials asked and run together (their episodes share the
                                   # worker processes); part of what the seed reproduces
      startup: 10                  # trials drawn at random before the sampler models the loss
      screen: {populations: [10, 30, 50], speeds: [0.04, 0.08], seeds: [1, 2],
               duration: 2000.0}   # the reduced study every trial runs (a study section)
      confirm: {candidates: 3}     # the best screened trials, rerun on the full study (the
                                   # config's study section, or `study:` here)
      objective: {ratio_target: 0.43, ratio_weight: 1.0}
      purpose: profile             # or existence: deliberately wide ranges that ask whether
                                   # any model of the family reaches the paper; its best
                                   # trial is written as best_trial.yaml, not as a profile
      parameters:                  # dotted schema key -> its range
        controller.beeclust.alpha: {low: 2.0, high: 40.0, log: true}
        world.control_steps: {low: 1, high: 4}             # a whole-number parameter
        sensing.ground_transfer: {choices: [linear, webots]}

A float or int parameter takes ``low``, ``high`` and optionally ``log`` (and ``step`` for
ints); any parameter may take ``choices`` instead. Every key and every bound is checked against
the schema when the design is loaded: an unknown key, a bound outside the parameter's allowed
range or an inverted range is refused with a message that names it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mona_controller.keys import leaf
from mona_controller.mappings import from_mapping, to_mapping
from mona_controller.schema import ParameterError
from swarm_supervisor.analysis.speed_effect import PAPER_RATIO  # table 2's, re-exported
from swarm_supervisor.config import DESIGN_KEYS, StudyParams, SwarmConfig, load_config
from swarm_supervisor.yaml_text import parse_yaml

#: The keys of the ``calibrate`` mapping.
KEYS = ('config', 'seed', 'trials', 'batch', 'startup', 'screen', 'confirm', 'objective',
        'purpose', 'parameters')
#: The keys a search folder does not hold its design to: trial n is the same whatever the
#: number of trials (its sampler is seeded with the seed and n), and the confirmations run
#: in study folders of their own. Raise ``trials`` and the same command carries on; lower it
#: to the trials scored to stop there and confirm.
UNDIGESTED = ('trials', 'confirm')
#: What a search is for: a profile to run the model with (ranges that public material
#: supports), or an existence question (wide ranges, defensible or not).
PURPOSES = ('profile', 'existence')


class CalibrationError(ParameterError):
    """A calibration design is malformed (exit status 2, the message names the key)."""


@dataclasses.dataclass(frozen=True)
class Range:
    """The range of one parameter: numbers between ``low`` and ``high`` (on a log scale if
    ``log``; whole numbers with ``step`` for an int parameter), or one of ``choices``."""

    key: str  #: dotted schema key, e.g. ``controller.beeclust.alpha``
    kind: str  #: 'float', 'int' or 'choice'
    low: float = 0.0
    high: float = 0.0
    log: bool = False
    step: int = 1
    choices: tuple[Any, ...] = ()


@dataclasses.dataclass(frozen=True)
class Objective:
    """What a trial's loss counts: every claim that does not hold, plus ``ratio_weight`` for
    each decade that the mean cue's SS_speed / SS_population lies off ``ratio_target``."""

    ratio_target: float = PAPER_RATIO
    ratio_weight: float = 1.0


@dataclasses.dataclass(frozen=True)
class CalibrationDesign:
    """A loaded, checked calibration design (see the module docstring)."""

    path: Path
    config: SwarmConfig  #: the parameter file trials start from
    seed: int
    trials: int
    batch: int
    startup: int
    screen: StudyParams
    confirm_study: StudyParams
    candidates: int
    objective: Objective
    parameters: tuple[Range, ...]
    purpose: str  #: one of :data:`PURPOSES`
    #: sha256 of what decides the screened trials (every key but ``trials`` and ``confirm``)
    #: and the base config's values: a search folder belongs to one design, whose trial
    #: count and confirmation may change (the trials are the same, whatever the count)
    digest: str

    def trial_config(self, values: Mapping[str, Any], study: StudyParams) -> SwarmConfig:
        """The configuration of a trial: the base config with ``values`` set, on ``study``."""
        return self.config.replace(study=to_mapping(study)).with_values(values)


def _where(*parts: str) -> str:
    return '.'.join(('calibrate', *parts))


def _mapping(value: Any, where: str) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise CalibrationError(f'{where} must be a mapping, not {value!r}')
    return value


def _whole(value: Any, where: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise CalibrationError(f'{where} = {value!r}: expected a whole number >= {low}')
    return value


def _study(base: StudyParams, values: Any, where: str) -> StudyParams:
    mapping = {**to_mapping(base), **_mapping(values, where)}
    try:
        return from_mapping(StudyParams, mapping, 'study.')
    except ParameterError as error:
        raise CalibrationError(f'{where}: {error}') from None


def _range(key: str, text: Any, config: SwarmConfig) -> Range:
    """One parameter's range, checked against the schema (its type and allowed values); a
    key that moved is replaced by its new one."""
    where = _where('parameters', key)
    try:
        key, current, spec = leaf(config, key)
    except ParameterError:
        raise CalibrationError(f'{where}: no parameter {key} (a searched parameter is a dotted '
                               'key of the episode, mona, world, sensing, controller or '
                               'metrics section)') from None
    if key in DESIGN_KEYS or key.startswith('study.'):
        raise CalibrationError(f'{where}: {key} is set by the studies of the design, not '
                               'searched')
    text = _mapping(text, where)

    def legal(value: Any, label: str) -> Any:
        try:
            return config.with_values({key: value}).value(key)
        except ParameterError as error:
            raise CalibrationError(f'{where}: {label} {value!r} is not allowed: {error}') \
                from None

    if 'choices' in text:
        unknown = sorted(set(text) - {'choices'})
        if unknown:
            raise CalibrationError(f'{where}: {unknown[0]} does not go with choices')
        choices = text['choices']
        if not isinstance(choices, list) or len(choices) < 2 or len(set(map(str, choices))) \
                != len(choices):
            raise CalibrationError(f'{where}.choices = {choices!r}: expected a list of at '
                                   'least two different values')
        return Range(key, 'choice', choices=tuple(legal(c, 'choice') for c in choices))
    if spec.keyed or isinstance(current, (bool, str, tuple)):
        raise CalibrationError(f'{where}: {key} is not a number: give its choices '
                               '({choices: [...]})')
    unknown = sorted(set(text) - {'low', 'high', 'log', 'step'})
    if unknown:
        raise CalibrationError(f'{where}: unknown key {unknown[0]} (a range has low, high, '
                               'log, step; or choices)')
    for bound in ('low', 'high'):
        if bound not in text:
            raise CalibrationError(f'{where}: {bound} is missing')
    low, high = legal(text['low'], 'low'), legal(text['high'], 'high')
    if not low < high:
        raise CalibrationError(f'{where}: low {low!r} must be below high {high!r}')
    log = text.get('log', False)
    if not isinstance(log, bool) or (log and low <= 0):
        raise CalibrationError(f'{where}.log = {log!r}: expected true or false, and a log '
                               'range needs low > 0')
    if isinstance(current, int):
        step = _whole(text.get('step', 1), f'{where}.step', 1)
        return Range(key, 'int', low=low, high=high, log=log, step=step)
    if 'step' in text:
        raise CalibrationError(f'{where}: step is for whole-number parameters')
    return Range(key, 'float', low=float(low), high=float(high), log=log)


def load_design(path: str | Path) -> CalibrationDesign:
    """Read and check a calibration design.

    Raises:
        CalibrationError: the file is missing, not YAML, or a key or value is wrong (named).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise CalibrationError(f'cannot read {path}: {error.strerror}') from None
    document = parse_yaml(text, str(path), CalibrationError)
    if not isinstance(document, dict) or set(document) != {'calibrate'}:
        raise CalibrationError(f'{path}: expected one mapping, calibrate: (see '
                               'ros_ws/config/designs/calibration.yaml)')
    try:
        return _checked(path, _mapping(document['calibrate'], 'calibrate'))
    except CalibrationError as error:
        raise CalibrationError(f'{path}: {error}') from None


def _checked(path: Path, body: dict[str, Any]) -> CalibrationDesign:
    unknown = sorted(set(body) - set(KEYS))
    if unknown:
        raise CalibrationError(f'unknown key {_where(unknown[0])}; known: {", ".join(KEYS)}')
    config_path = body.get('config')
    try:
        config = load_config(None if config_path is None else path.parent / config_path)
    except ParameterError as error:
        raise CalibrationError(f'{_where("config")}: {error}') from None
    parameters = _mapping(body.get('parameters'), _where('parameters'))
    if not parameters:
        raise CalibrationError(f'{_where("parameters")}: name at least one parameter to search')
    ranges = tuple(_range(str(key), value, config) for key, value in parameters.items())
    confirm = _mapping(body.get('confirm'), _where('confirm'))
    extra = sorted(set(confirm) - {'candidates', 'study'})
    if extra:
        raise CalibrationError(f'unknown key {_where("confirm", extra[0])} (candidates, study)')
    objective = _mapping(body.get('objective'), _where('objective'))
    extra = sorted(set(objective) - {'ratio_target', 'ratio_weight'})
    if extra:
        raise CalibrationError(f'unknown key {_where("objective", extra[0])} (ratio_target, '
                               'ratio_weight)')
    numbers = {}
    for name, default, positive in (('ratio_target', PAPER_RATIO, True),
                                    ('ratio_weight', 1.0, False)):
        value = objective.get(name, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value) or value < 0 or (positive and value <= 0):
            raise CalibrationError(f'{_where("objective", name)} = {value!r}: expected a '
                                   f'{"positive" if positive else "non-negative"} number')
        numbers[name] = float(value)
    purpose = body.get('purpose', PURPOSES[0])
    if purpose not in PURPOSES:
        raise CalibrationError(f'{_where("purpose")} = {purpose!r}: expected one of '
                               f'{", ".join(PURPOSES)}')
    return CalibrationDesign(
        path=path, config=config,
        seed=_whole(body.get('seed', 1), _where('seed'), 0),
        trials=_whole(body.get('trials', 20), _where('trials'), 1),
        batch=_whole(body.get('batch', 2), _where('batch'), 1),
        startup=_whole(body.get('startup', 10), _where('startup'), 0),
        screen=_study(config.study, body.get('screen'), _where('screen')),
        confirm_study=_study(config.study, confirm.get('study'), _where('confirm', 'study')),
        candidates=_whole(confirm.get('candidates', 3), _where('confirm', 'candidates'), 0),
        objective=Objective(**numbers), parameters=ranges, purpose=purpose,
        digest=hashlib.sha256(json.dumps(
            [{key: value for key, value in body.items() if key not in UNDIGESTED},
             config.to_dict()], sort_keys=True).encode()).hexdigest())

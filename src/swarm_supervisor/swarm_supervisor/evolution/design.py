"""An evolution design: the net, the optimiser and the episodes every genome is scored on.

A design is a YAML file with one mapping, ``evolve``::

    evolve:
      config: ../mona_swarm.yaml   # the parameter file every episode starts from (relative
                                   # to this file; default: the shipped one)
      seed: 1                      # the run's seed (the optimiser and the training
                                   # seeds), >= 1
      strategy: cma_es             # the optimiser: cma_es (pycma) or openai_es
                                   # (evolution.strategies)
      learning_rate: 0.01          # openai_es: Adam's step size
      genomes: 16                  # the population: genomes per generation (even for
                                   # openai_es, whose pairs are antithetic); 0: pycma's
                                   # default for the genome's size, 4 + 3 ln n (cma_es)
      diagonal: false              # cma_es: a diagonal covariance (sep-CMA-ES, Ros and
                                   # Hansen 2008: learning rates about (n + 2) / 3 times
                                   # the full matrix's)
      generations: 30
      episodes: 4                  # episodes per genome, on the same seeds for every genome
                                   # of a generation (fresh seeds each generation)
      robots: 30                   # N
      duration: 1000.0             # s per episode
      sigma: 0.5                   # the initial step size (openai_es keeps it)
      start: zero                  # the genome the search starts from: zero (all weights
                                   # 0), or drives (the kind's start: a net that drives,
                                   # evolution.genomes)
      kind: network                # the controller kind evolved (evolution.genomes)
      hidden: 8                    # the net: hidden neurons (controller.<kind>.hidden)
      recurrent: false             # network: an Elman net (controller.network.recurrent)
      max_speed: 0.0               # m/s, the net's top wheel speed (controller.<kind>.
                                   # max_speed; 0: the Mona's top command)
      clean_stops: false           # network: it cleans only standing (controller.network.
                                   # clean_stops); with max_speed, the fair match
      batch: 32                    # at most this many episodes stepped together per worker
      validation: 0                # seeds of the fixed validation set (0: none); then
                                   # best.npz is the optimiser's mean with the best
                                   # validation score, not the best training score
      validate_every: 1            # generations between two validations of the mean
      validation_duration: 0.0     # s per validation episode (0: duration)
      patience: 0                  # stop once this many validations in a row have not
                                   # improved on the best (0: run every generation)
      held_out: 100                # then: the best genome and BEECLUST on this many held-out
                                   # seeds (0: none; evolution.compare)
      compare: [../mona_swarm.yaml, moving_leaks.yaml]   # on these parameter files
                                   # (relative to this file; default: the design's config)

Every key is checked when the design is loaded: an unknown key or a value out of range is
refused with a message that names it (:class:`EvolutionError`, exit status 2).
``generations`` and ``patience`` may be raised (or ``generations`` lowered to the generations
done) between runs of one folder: they only say where the run stops, so they are not part of
what a resumed run must match (:meth:`Design.digest`).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

from mona_controller.controllers.network_weights import MAX_HIDDEN
from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.evolution.genomes import ARCHITECTURES, architecture
from swarm_supervisor.evolution.strategies import STRATEGIES
from swarm_supervisor.yaml_text import read_yaml


class EvolutionError(ParameterError):
    """An evolution design is malformed (exit status 2, the message names the key)."""


#: Each key of the ``evolve`` mapping: (type, low, high, default); None = no default.
KEYS: dict[str, tuple[type, float | None, float | None, Any]] = {
    'config': (str, None, None, ''),
    'seed': (int, 1, 2**31 - 1, 1),
    'strategy': (str, None, None, 'cma_es'),
    'learning_rate': (float, 1e-6, 10.0, 0.01),
    'genomes': (int, 0, 4096, 16),
    'diagonal': (bool, None, None, False),
    'generations': (int, 1, 100_000, 30),
    'episodes': (int, 1, 1000, 4),
    'robots': (int, 1, 10_000, 30),
    'duration': (float, 1e-3, 1e6, 1000.0),
    'sigma': (float, 1e-6, 1e3, 0.5),
    'start': (str, None, None, 'zero'),
    'kind': (str, None, None, 'network'),
    'hidden': (int, 1, MAX_HIDDEN, 8),
    'recurrent': (bool, None, None, False),
    'max_speed': (float, 0.0, 1.0, 0.0),
    'clean_stops': (bool, None, None, False),
    'batch': (int, 1, 4096, 32),
    'validation': (int, 0, 100_000, 0),
    'validate_every': (int, 1, 100_000, 1),
    'validation_duration': (float, 0.0, 1e6, 0.0),
    'patience': (int, 0, 100_000, 0),
    'held_out': (int, 0, 100_000, 0),
    'compare': (list, None, None, []),
}
#: Keys added after the first designs ran: left out of the digest at their defaults, so
#: those designs' folders resume as before.
_LATER = ('diagonal', 'start', 'kind', 'validation', 'validate_every',
          'validation_duration')
#: The keys of the post-evaluation, which leave the evolution itself unchanged, and
#: ``generations``, which only says where it stops (a run may be extended).
AFTERWARDS = ('generations', 'patience', 'held_out', 'compare')
#: The starts a design may name (``evolve.start``).
STARTS = ('zero', 'drives')


@dataclasses.dataclass(frozen=True)
class Design:
    """A loaded, checked design (:data:`KEYS`); ``base`` is the parameter set it starts from."""

    path: str
    base: SwarmConfig
    config: str
    seed: int
    strategy: str
    learning_rate: float
    genomes: int
    diagonal: bool
    generations: int
    episodes: int
    robots: int
    duration: float
    sigma: float
    start: str
    kind: str
    hidden: int
    recurrent: bool
    max_speed: float
    clean_stops: bool
    batch: int
    validation: int
    validate_every: int
    validation_duration: float
    patience: int
    held_out: int
    compare: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """The design's keys and values."""
        return {key: list(value) if isinstance(value, tuple) else value
                for key, value in ((key, getattr(self, key)) for key in KEYS)}

    @property
    def genome_size(self) -> int:
        """The number of weights the optimiser searches over."""
        return architecture(self.kind).size(self)

    @property
    def population(self) -> int:
        """Genomes per generation: ``genomes``, or pycma's default for the genome's size
        (``4 + int(3 ln n)``, its option ``popsize``) where ``genomes`` is 0."""
        return self.genomes or 4 + int(3 * math.log(self.genome_size))

    def digest(self) -> str:
        """What a resumed run must match: the keys and the base parameters."""
        design = {k: v for k, v in self.to_dict().items() if k not in AFTERWARDS}
        if self.strategy == 'cma_es':  # as before the keys existed: cma_es reads neither
            del design['strategy'], design['learning_rate']
        for key in _LATER:  # as before these keys existed, where a design leaves them out
            if design[key] == KEYS[key][3]:
                del design[key]
        return json.dumps({'design': design, 'base': self.base.to_dict()},
                          sort_keys=True, default=str)


def _checked(key: str, value: Any) -> Any:
    kind, low, high, _ = KEYS[key]
    name = f'evolve.{key}'
    if kind is list:
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise EvolutionError(f'{name} = {value!r}: expected a list of parameter files')
        return value
    if kind is bool or kind is str:
        if not isinstance(value, kind):
            raise EvolutionError(f'{name} = {value!r}: expected '
                                 + ('true or false' if kind is bool else 'a string'))
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise EvolutionError(f'{name} = {value!r}: expected a number')
    if kind is int:
        if isinstance(value, float) and not value.is_integer():
            raise EvolutionError(f'{name} = {value!r}: expected a whole number')
        value = int(value)
    value = kind(value)
    if (low is not None and value < low) or (high is not None and value > high):
        raise EvolutionError(f'{name} = {value!r} is out of range: allowed [{low:g}, {high:g}]')
    return value


def design_from_mapping(document: Any, path: str | Path = 'the design') -> Design:
    """Check a parsed design (``{'evolve': {...}}``); ``config`` is relative to ``path``.

    Raises:
        EvolutionError: naming the key that is unknown, missing or out of range.
    """
    if not isinstance(document, dict) or set(document) != {'evolve'}:
        raise EvolutionError(f"{path}: expected one mapping, 'evolve'")
    section = document['evolve'] or {}
    if not isinstance(section, dict):
        raise EvolutionError(f'{path}: evolve must be a mapping')
    unknown = sorted(set(section) - set(KEYS))
    if unknown:
        raise EvolutionError(f'{path}: unknown key evolve.{unknown[0]}; known: '
                             + ', '.join(KEYS))
    values = {key: _checked(key, section.get(key, default))
              for key, (_, _, _, default) in KEYS.items()}
    if values['strategy'] not in STRATEGIES:
        raise EvolutionError(f"{path}: evolve.strategy = {values['strategy']!r}: one of "
                             + ', '.join(STRATEGIES))
    if values['start'] not in STARTS:
        raise EvolutionError(f"{path}: evolve.start = {values['start']!r}: one of "
                             + ', '.join(STARTS))
    if values['kind'] not in ARCHITECTURES:
        raise EvolutionError(f"{path}: evolve.kind = {values['kind']!r}: one of "
                             + ', '.join(ARCHITECTURES))
    if values['strategy'] == 'openai_es' and values['genomes'] == 0:
        raise EvolutionError(f'{path}: evolve.genomes = 0 (the library default) is for '
                             'cma_es; openai_es needs an even number')
    if values['genomes'] == 1:
        raise EvolutionError(f'{path}: evolve.genomes = 1 is out of range: allowed 0 (the '
                             'default for the size) or [2, 4096]')
    if values['diagonal'] and values['strategy'] != 'cma_es':
        raise EvolutionError(f'{path}: evolve.diagonal is an option of cma_es')
    if values['patience'] and not values['validation']:
        raise EvolutionError(f'{path}: evolve.patience counts validations: set '
                             'evolve.validation > 0 too')
    if values['strategy'] == 'openai_es' and values['genomes'] % 2:
        raise EvolutionError(f"{path}: evolve.genomes = {values['genomes']}: openai_es "
                             'needs an even number (its pairs are antithetic)')
    config = values['config']
    if config:
        config = str((Path(path).parent / config).resolve())
        values['config'] = config
    try:
        base = load_config(config or None)
    except ParameterError as error:
        raise EvolutionError(f'{path}: evolve.config: {error}') from None
    compare = [str((Path(path).parent / name).resolve()) for name in values['compare']]
    for k, name in enumerate(compare):
        try:
            load_config(name)
        except ParameterError as error:
            raise EvolutionError(f'{path}: evolve.compare[{k}]: {error}') from None
    values['compare'] = tuple(compare)
    return Design(path=str(path), base=base, **values)


def load_design(path: str | Path) -> Design:
    """Load and check a design file.

    Raises:
        EvolutionError: the file is missing, not YAML, or a key is bad (named).
    """
    return design_from_mapping(read_yaml(path, EvolutionError), path)

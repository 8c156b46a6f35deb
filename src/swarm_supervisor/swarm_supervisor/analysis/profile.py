"""Which Monas a study ran: its sensing and encounter chain, named as a profile.

The chain (docs/model.md, "The paper's simulated Monas") is the set of parameters that say
how a Mona senses the cue and meets others. A profile is a parameter file of
``ros_ws/config/profiles/`` that sets them; report.md names the profile whose chain equals the
episodes', or lists how the chain differs from the idealised default.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from swarm_supervisor.config import (
    DEFAULT_CONFIG,
    SwarmConfig,
    current_keys,
    load_config,
    mapping_value,
)

#: The parameters of the sensing and encounter chain, by dotted key.
MODEL_CHAIN: tuple[str, ...] = (
    'mona.ground_transfer', 'mona.ground_height', 'mona.ground_lut', 'mona.ground_reflection',
    'mona.ground_roughness', 'mona.ground_calibration', 'mona.ground_table',
    'mona.ground_baseline', 'mona.ground_offset', 'mona.ground_footprint', 'mona.ground_noise',
    'mona.ir_count', 'mona.ir_span', 'mona.ir_range', 'mona.ir_robot_factor',
    'mona.robot_detection', 'mona.wall_margin', 'mona.command_latency', 'world.cell_size',
    'world.cleaning', 'world.control_steps', 'controller.beeclust.turn_at',
)
#: The shipped profiles (in the source tree).
PROFILES_DIR = DEFAULT_CONFIG.parent / 'profiles'


def chain_of(parameters: Mapping[str, Any]) -> dict[str, str]:
    """The chain's values in a record's ``parameters`` (``SwarmConfig.to_dict`` form), each as
    JSON so that lists and numbers compare exactly; a key the record lacks is its default."""
    defaults = SwarmConfig().to_dict()
    parameters = current_keys(parameters)
    return {key: json.dumps(mapping_value(parameters, key, mapping_value(defaults, key)))
            for key in MODEL_CHAIN}


def shipped_profiles(folder: Path = PROFILES_DIR) -> dict[str, dict[str, str]]:
    """Each profile file's name -> its chain (none if the folder is not there)."""
    if not folder.is_dir():
        return {}
    return {path.stem: chain_of(load_config(path).to_dict())
            for path in sorted(folder.glob('*.yaml'))}


def describe(records: Sequence[Mapping[str, Any]], folder: Path = PROFILES_DIR) -> str:
    """One line for report.md: the profile the episodes ran, and how it departs from the
    idealised default (the first episode's parameters; report.md warns separately when
    parameters differ between episodes)."""
    chain = chain_of(records[0].get('parameters', {})) if records else {}
    default = chain_of({})
    changed = [f'`{key}` = {json.loads(value)}' for key, value in chain.items()
               if value != default[key]]
    named = [name for name, values in shipped_profiles(folder).items() if values == chain]
    name = (f'the `{named[0]}` profile (ros_ws/config/profiles/{named[0]}.yaml)' if named
            else 'a profile of its own')
    if not changed:
        return (f'- Monas: {name}: every link of the sensing and encounter chain at its '
                'idealised default (docs/model.md, "The paper\'s simulated Monas")')
    return (f'- Monas: {name}, which departs from the idealised default in '
            + ', '.join(changed) + ' (docs/model.md, "The paper\'s simulated Monas")')

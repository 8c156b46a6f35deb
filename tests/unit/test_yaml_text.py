"""YAML as every command reads it: a key given twice in one mapping is refused with its path
and both lines (YAML readers keep the last silently); a syntax error is one line."""

from __future__ import annotations

import pytest

from mona_controller.schema import ParameterError
from swarm_supervisor.analysis.claims import ClaimError
from swarm_supervisor.config import load_config
from swarm_supervisor.yaml_text import parse_yaml, read_yaml


@pytest.mark.parametrize('text, message', [
    ('a: 1\nb: 2\na: 3\n', r'f\.yaml line 3: a is given twice in one mapping \(first on line 1\)'),
    ('/**:\n  ros__parameters:\n    episode: {population: 3, seed: 1, population: 4}\n',
     r'line 3: episode\.population is given twice'),
    ('claims:\n  - id: a\n  - id: b\n    id: c\n', r'line 4: claims\[1\]\.id is given twice'),
    ('on: 1\nyes: 2\n', r'line 2: yes is given twice'),  # both are true to YAML 1.1
    ('a: [1\n', r'f\.yaml line 2: not valid YAML: expected'),
    ('a: 1\n---\nb: 2\n', r'f\.yaml line 2: not valid YAML: but found another document'),
])
def test_a_repeated_key_or_a_syntax_error_is_one_line_naming_where(text, message):
    with pytest.raises(ParameterError, match=message) as refused:
        parse_yaml(text, 'f.yaml')
    assert '\n' not in str(refused.value)


def test_the_same_key_in_two_mappings_and_merge_keys_are_fine():
    assert parse_yaml('a: {b: 1}\nc: {b: 2}\n', 'f') == {'a': {'b': 1}, 'c': {'b': 2}}
    assert parse_yaml('base: &b {x: 1}\nd: {<<: *b, x: 2}\n', 'f')['d'] == {'x': 2}
    assert parse_yaml('', 'f') is None


def test_every_reader_refuses_a_repeated_key(tmp_path):
    path = tmp_path / 'p.yaml'
    path.write_text('/**:\n  ros__parameters:\n    controller: {speed: 0.08}\n'
                    '    controller: {speed: 0.04}\n')
    with pytest.raises(ParameterError, match=r'p\.yaml line 4: controller is given twice'):
        load_config(path)
    with pytest.raises(ClaimError, match='cannot read .*nowhere.yaml: No such file'):
        read_yaml(tmp_path / 'nowhere.yaml', ClaimError)

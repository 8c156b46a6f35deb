"""Plug-ins: files named by a parameter file (relative to it), loaded once per process under a
name of their own, recorded with their SHA-256, refused in one line when they cannot load or
changed; an obstacle layout a plug-in registers, picked by world.layout.

These load files into this test process (a plug-in is loaded once per process): each test
writes files of its own and registers names no other test uses.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import pytest
import yaml

from mona_controller import plugins
from mona_controller.plugins import Plugin, PluginError
from mona_controller.schema import ParameterError
from swarm_supervisor.config import (
    SwarmConfig,
    file_relative_overrides,
    load_config,
    write_ros_yaml,
)
from swarm_supervisor.engine import run_episode
from swarm_world.layouts import LAYOUTS, register_layout

RING = '''"""Pillars around the first source."""
import math

from swarm_world.layouts import register_layout


def {name}(world):
    source = world.source_list()[0]
    return {{f'pillar_{{k}}': [source.x + {radius} * math.cos(k * math.pi / 2),
                               source.y + {radius} * math.sin(k * math.pi / 2), 0.05]
             for k in range(4)}}


register_layout({name!r}, {name})
'''


def parameter_file(folder: Path, plugin_paths: list[str], **sections) -> Path:
    path = folder / 'params.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': {
        'plugins': plugin_paths, **sections}}}))
    return path


def test_a_file_is_loaded_once_under_a_name_of_its_own_and_recorded(tmp_path: Path):
    for folder, name in (('a', 'ring_a'), ('b', 'ring_b')):  # one stem, two folders
        (tmp_path / folder).mkdir()
        (tmp_path / folder / 'ring.py').write_text(RING.format(name=name, radius=0.4))
    first = plugins.load_file(tmp_path / 'a' / 'ring.py')
    second = plugins.load_file(tmp_path / 'b' / 'ring.py')
    assert first.module != second.module and {'ring_a', 'ring_b'} <= set(LAYOUTS)
    assert first.path == str(tmp_path / 'a' / 'ring.py') and first.origin == 'file'
    assert first.sha256 == hashlib.sha256((tmp_path / 'a' / 'ring.py').read_bytes()).hexdigest()
    assert sys.modules[first.module].__file__ == first.path
    assert str(tmp_path / 'a') not in sys.path  # the user's folder stays off the path
    assert plugins.load_file(tmp_path / 'a' / 'ring.py') is first  # once per process
    assert Plugin.from_dict(json.loads(json.dumps(first.to_dict()))) == first
    # Another process loading the record gets the very same code, or a refusal.
    assert plugins.ensure([first]) == (first,)
    changed = Plugin(first.path, '0' * 64, first.module)
    with pytest.raises(PluginError, match=r'ring.py is not the code the run recorded'):
        plugins.ensure([changed])


def test_a_plugin_that_cannot_load_is_one_line_naming_the_file_the_error_and_line(
        tmp_path: Path):
    with pytest.raises(PluginError, match=r'plugins: cannot read the plug-in .*nowhere.py: '
                                          r'No such file.*docs/extending.md'):
        plugins.load_file(tmp_path / 'nowhere.py')
    (tmp_path / 'broken.py').write_text('import math\n\nvalue = 1 / 0\n')
    with pytest.raises(PluginError) as caught:
        plugins.load_file(tmp_path / 'broken.py')
    assert str(caught.value) == (f'plugins: the plug-in {tmp_path / "broken.py"} fails to '
                                 'import: ZeroDivisionError: division by zero (line 3)')
    assert plugins.module_name(tmp_path / 'broken.py') not in sys.modules
    with pytest.raises(PluginError, match=r"plugins = 'ring.py': expected a list"):
        plugins.resolve('ring.py', tmp_path)


def test_a_parameter_file_names_plugins_relative_to_itself(tmp_path: Path, monkeypatch):
    (tmp_path / 'mine').mkdir()
    (tmp_path / 'mine' / 'ring.py').write_text(RING.format(name='ring_relative', radius=0.5))
    path = parameter_file(tmp_path, ['mine/ring.py'], world={'layout': 'ring_relative'})
    monkeypatch.chdir(tmp_path / 'mine')  # not where the file is
    config = load_config(path)
    [plugin] = [p for p in config.plugins if p.origin == 'file']
    assert plugin.path == str(tmp_path / 'mine' / 'ring.py')
    assert config.plugin_records() == [p.to_dict() for p in config.plugins]
    assert 'plugins' not in config.to_dict()  # not a parameter: recorded beside them
    assert config.replace(episode={'seed': 3}).plugins == config.plugins
    arena = config.world.arena()
    assert [o.name for o in arena.obstacles] == [f'pillar_{k}' for k in range(4)]
    # Written back (a study's parameters.yaml): the absolute path, read back the same.
    write_ros_yaml(config, tmp_path / 'again.yaml')
    saved = yaml.safe_load((tmp_path / 'again.yaml').read_text())['/**']['ros__parameters']
    assert saved['plugins'] == [plugin.path]
    assert load_config(tmp_path / 'again.yaml') == config
    # The nodes get the absolute path (their --params-file cannot say where it came from).
    assert f'plugins:=["{plugin.path}"]' in file_relative_overrides(path)


def test_a_layout_joins_the_obstacles_and_keeps_the_robots_out(tmp_path: Path):
    (tmp_path / 'ring.py').write_text(RING.format(name='ring_run', radius=0.45))
    config = load_config(parameter_file(
        tmp_path, ['ring.py'], world={'layout': 'ring_run', 'obstacles': {'post': [0.3, 0.3,
                                                                                   0.05]}}))
    arena = config.world.arena()
    assert [o.name for o in arena.obstacles] == ['pillar_0', 'pillar_1', 'pillar_2',
                                                 'pillar_3', 'post']
    result = run_episode(config.replace(episode={'population': 15, 'duration': 10.0}))
    for poses in (result.initial_poses, result.final_poses):  # placed clear, kept out
        assert min(arena.clearance(x, y) for x, y in poses[:, :2]) > 0.04 - 0.0048
    # The cue stays the paper's under a layout unless it is cleared there, as asked.
    assert config.world.paper_field
    cleared = config.replace(world={'obstacle_cue': 'clear'})
    assert not cleared.world.paper_field
    under = arena.under(config.world.cells, config.world.cell_size)
    assert under.any() and not run_episode(cleared.replace(episode={
        'population': 2, 'duration': 0.1})).final_cue[under].any()


def test_a_bad_layout_is_refused_naming_world_layout_or_the_recipe(tmp_path: Path):
    with pytest.raises(ParameterError, match=r"world.layout = 'nope' is not a registered "
                                             r'layout .*docs/extending.md#an-obstacle-layout'):
        SwarmConfig().replace(world={'layout': 'nope'})
    register_layout('outside_layout', lambda world: {'far': [9.0, 9.0, 0.1]})
    register_layout('failing_layout', lambda world: 1 / 0)
    register_layout('list_layout', lambda world: [[1.0, 1.0, 0.1]])
    register_layout('clashing_layout', lambda world: {'post': [1.0, 1.0, 0.05]})
    with pytest.raises(ParameterError, match=r"world.layout = 'outside_layout': obstacle far: "
                                             r'the point .* is outside'):
        SwarmConfig().replace(world={'layout': 'outside_layout'})
    with pytest.raises(ParameterError, match=r"world.layout = 'failing_layout' fails: "
                                             r'ZeroDivisionError'):
        SwarmConfig().replace(world={'layout': 'failing_layout'})
    with pytest.raises(ParameterError, match=r"world.layout = 'list_layout' returned list"):
        SwarmConfig().replace(world={'layout': 'list_layout'})
    with pytest.raises(ParameterError, match=r"world.obstacles.post: the layout "
                                             r"'clashing_layout' has an obstacle of that name"):
        SwarmConfig().replace(world={'layout': 'clashing_layout',
                                     'obstacles': {'post': [0.5, 0.5, 0.05]}})
    with pytest.raises(ValueError, match='registered already'):
        register_layout('outside_layout', lambda world: {})


def test_an_unknown_kind_or_metric_names_the_recipe():
    with pytest.raises(ParameterError, match=r"controller.kind = 'mine' is not allowed: .*"
                                             r'docs/extending.md#a-controller'):
        SwarmConfig().replace(controller={'kind': 'mine'})
    from swarm_supervisor.analysis.claims import ClaimError, parse_claim
    with pytest.raises(ClaimError, match=r"not 'under_me' .*docs/extending.md#a-metric"):
        parse_claim({'id': 'x', 'where': 'w', 'paper': 'p', 'check': {
            'kind': 'threshold', 'metric': 'under_me', 'at': 'end', 'op': '<', 'value': 1}})


def test_an_installed_package_adds_plugins_through_its_entry_point(tmp_path: Path,
                                                                   monkeypatch):
    dist = tmp_path / 'my_layouts-1.0.dist-info'  # what pip installs: metadata, the module
    dist.mkdir()
    (dist / 'METADATA').write_text('Metadata-Version: 2.1\nName: my-layouts\nVersion: 1.0\n')
    (dist / 'entry_points.txt').write_text('[mona_swarm.plugins]\nlayouts = my_layouts\n')
    (tmp_path / 'my_layouts.py').write_text(RING.format(name='ring_installed', radius=0.4))
    monkeypatch.syspath_prepend(str(tmp_path))
    config = load_config()  # any parameter file: installed plug-ins load with every one
    [record] = [p for p in config.plugins if p.module == 'my_layouts']
    assert (record.origin, record.name) == ('entry point', 'layouts')
    assert record.path == str(tmp_path / 'my_layouts.py')
    assert record.sha256 == hashlib.sha256((tmp_path / 'my_layouts.py').read_bytes()).hexdigest()
    assert config.replace(world={'layout': 'ring_installed'}).world.arena().obstacles

"""The shipped learned and baseline controllers unchanged in the node system: one controller
process per Mona running ros_ws/config/controllers/stand_net.yaml (the evolved net) or
solo.yaml, on a world whose cleaning needs company (``world.cleaning_quorum`` 2), records
the same bag as the embedded runner: poses, the controllers' states, cleaning events, cue
maps and metrics, decoded by an independent decoder (mcap + mcap-ros2-support)."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import pytest

from swarm_supervisor.config import load_config, write_ros_yaml
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.outputs.bag import record_episode

sys.path.insert(0, str(Path(__file__).parents[1] / 'system'))
from test_embedded_bag import COMPARED, mcap_messages, plain  # noqa: E402

from swarmrun import CONFIG, SwarmRun  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.slow]

CONTROLLERS = Path(__file__).resolve().parents[2] / 'ros_ws' / 'config' / 'controllers'
#: Pairs clean, lone robots do not; wide enough that some pairs form in a short episode.
COMPANY = {'cleaning_quorum': 2, 'cleaning_range': 0.6}


@pytest.mark.parametrize('name', ['stand_net.yaml', 'solo.yaml'])
def test_a_shipped_controller_as_nodes_records_the_embedded_bag(tmp_path, name):
    shipped = load_config(CONTROLLERS / name)
    config = dataclasses.replace(load_config(CONFIG), controller=shipped.controller).replace(
        world=COMPANY, episode={'population': 8, 'duration': 8.0, 'seed': 4})
    path = tmp_path / 'learned.yaml'
    write_ros_yaml(config, path)
    # Four controllers per process: the layout is not what this compares (the default one
    # process per robot is compared in test_embedded_bag), and each process costs a start-up.
    run = SwarmRun(tmp_path / 'run', ['--config', str(path), '--mode', 'lockstep',
                                      '--controllers-per-process', '4'])
    try:
        status = run.wait()
    finally:
        run.stop()
    assert status == 0, run.stderr
    _, closed = record_episode(config, tmp_path / 'embedded')
    node = mcap_messages(run.out / 'episode_0' / 'bag')
    embedded = mcap_messages(closed.path)
    for topic in COMPARED:
        assert [(t, plain(topic, m)) for t, m in embedded[topic]] == \
            [(t, plain(topic, m)) for t, m in node[topic]], topic
    parameters = json.loads(node['/episode'][0][1].data)['parameters']
    assert parameters['controller']['kind'] == shipped.controller.kind
    assert parameters['world']['cleaning_quorum'] == 2
    assert len(node['/world/cleaning']) > 0  # pairs formed and cleaned
    # ... and lone robots stood without cleaning: the quorum was at work.
    episode, standing, cleaned = Episode(config), 0, 0
    while not episode.done:
        step = episode.step()
        if step.time_ns // 10**9 != step.before_ns // 10**9:  # a cleaning tick
            standing += int(step.command.cleaner.sum())
            cleaned += len(step.cleaned)
    assert 0 < cleaned < standing

"""The shipped layout on a node-system bag (scripts/swarm.sh, lockstep), opened in a real
browser: the same checks as an embedded bag's, among obstacles (examples/
obstacle_layout.yaml), on the states the controllers published (`mona_<i>/state`, assembled
by the world into `/world/robot_states`)."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from checks import settle
from conftest import LAYOUT, REPO
from foxapp import FoxgloveApp, app_url
from shown import expected_at

sys.path.insert(0, str(Path(__file__).parents[1] / 'system'))
from swarmrun import SwarmRun  # noqa: E402

pytestmark = [pytest.mark.slow, pytest.mark.ros]
POPULATION, DURATION, SEED = 8, 40.0, 4
SEEK = 30.5  # after the 30 s cue map, between two metric samples
OBSTACLES = REPO / 'examples' / 'obstacle_layout.yaml'
#: examples/obstacle_layout.yaml's six pillars (r = 6 cm) alone (the wedge and the wall add).
PILLARS = 6 * np.pi * 0.06 ** 2


@pytest.fixture(scope='module')
def bag(data_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A lockstep episode's bag, served at /data/nodes/bag/bag.mcap."""
    run = SwarmRun(tmp_path_factory.mktemp('nodes') / 'run',
                   ['--population', str(POPULATION), '--duration', str(DURATION), '--seed',
                    str(SEED), '--mode', 'lockstep', '--config', str(OBSTACLES)])
    try:
        status = run.wait()
    finally:
        run.stop()
    assert status == 0, run.stderr
    shutil.copytree(run.out / 'episode_0' / 'bag', data_dir / 'nodes' / 'bag')
    return data_dir / 'nodes' / 'bag'


def test_the_layout_shows_a_node_system_bag(browser, server, shots, bag):
    expected = expected_at(bag, SEEK, LAYOUT, 'lockstep')
    assert expected.states is not None  # the node system records the controllers' states
    expected = type(expected)(**{**expected.__dict__, 'obstacle_area': PILLARS})
    app = FoxgloveApp(browser, shots)
    try:
        took = app.open(app_url(server.url, f'{server.url}/data/nodes/bag/bag.mcap', SEEK))
        view, found = settle(app, expected)
        print(f'opened in {took:.1f} s; {app.save("node_system_bag")}')
    finally:
        app.close()
    assert found == []
    assert view.clock == pytest.approx(SEEK, abs=0.01)

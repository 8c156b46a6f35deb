"""The shipped layout on the node system (`scripts/swarm.sh --live`, lockstep, among the
obstacles of examples/obstacle_layout.yaml), opened in a real browser: first live, as the
episode runs and after it has ended (the live node keeps serving the final state), then the
metrics node's bag over HTTP, with the same checks as the embedded runner's: robots in the
states the controllers published (`mona_<i>/state`, assembled by the world into
`/world/robot_states`), where the bag puts them, the sources and the obstacles drawn."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from checks import Expected, plots_of, settle
from conftest import LAYOUT
from foxapp import STATUS, FoxgloveApp, app_url
from shown import expected_at

from liverun import LEGACY_SUBPROTOCOL, SharedRun, accepts_legacy_subprotocol

pytestmark = [pytest.mark.slow, pytest.mark.ros]
SEEK = 70.5  # after the 70 s cue map, between two metric samples
#: examples/obstacle_layout.yaml's six pillars (r = 6 cm) alone (the wedge and the wall add).
PILLARS = 6 * np.pi * 0.06 ** 2


@pytest.fixture
def run(node_live: SharedRun) -> SharedRun:
    """The node system's lingering live run (tests/liverun.py): lockstep, N = 5, seed 4,
    80 s, among examples/obstacle_layout.yaml's obstacles, held to real time at most
    (real_time_factor 1.0: lockstep alone runs several times faster); the page opens as
    soon as the live node listens (the world waits for the controllers meanwhile), and 80 sim
    seconds leave time to load it and read a running status while the episode runs, even on a
    busy machine (the panels may fill after the end)."""
    return node_live


@pytest.fixture
def bag(run: SharedRun, data_dir: Path) -> Path:
    """The metrics node's bag, served at /data/nodes/bag/bag.mcap, once the run is done."""
    run.wait_lingering()
    served = data_dir / 'nodes' / 'bag'
    if not served.exists():
        shutil.copytree(run.out / 'episode_0' / 'bag', served)
    return served


def test_the_live_view_shows_the_node_system_and_keeps_it_after_the_end(browser, server,
                                                                         shots, run):
    run.run.wait_for(lambda: 'live view on ws://' in run.run.log('live'), 'the live view')
    assert accepts_legacy_subprotocol(run.url), LEGACY_SUBPROTOCOL  # the web build's only one
    live = Expected(population=run.population, seed=run.seed, mode='lockstep',
                    plots=plots_of(LAYOUT), obstacle_area=PILLARS)
    app = FoxgloveApp(browser, shots)
    try:
        took = app.open(app_url(server.url, run.url))
        # Sim time advances on screen while the episode runs: read at once, from the status
        # panel's text alone, so no look (screenshots, several a minute on a busy machine)
        # stands between the page and the episode's end.
        first, later = app.sim_time_advances(run.duration)
        print(f'opened in {took:.1f} s; running at {first:g} s, then {later:g} s')
        view, found = settle(app, live)  # every panel fills (maybe only after the end)
        print(app.save('node_system_live'))
        assert found == []
        # Until the end the window is minimised (the user looks elsewhere): the page takes
        # every message in but draws none, and is shown again for the final look.
        with app.minimised():
            run.wait_lingering()
        final, found = settle(app, live, enough=lambda found: not found and
                              '"state": "finished"' in app.text(STATUS))
        print(app.save('node_system_live_after_the_end'))
    finally:
        app.close()
    assert found == []
    assert '"state": "finished"' in final.status_text
    assert final.status_time == run.duration


def test_the_layout_shows_a_node_system_bag(browser, server, shots, bag):
    expected = expected_at(bag, SEEK, LAYOUT, 'lockstep')
    assert expected.states is not None  # the node system records the controllers' states
    expected = Expected(**{**expected.__dict__, 'obstacle_area': PILLARS})
    app = FoxgloveApp(browser, shots)
    try:
        took = app.open(app_url(server.url, f'{server.url}/data/nodes/bag/bag.mcap', SEEK))
        view, found = settle(app, expected)
        print(f'opened in {took:.1f} s; {app.save("node_system_bag")}')
    finally:
        app.close()
    assert found == []
    assert view.clock == pytest.approx(SEEK, abs=0.01)

"""The shipped layout on an embedded run (`mona-swarm run --live --bag`), opened in a real
browser as a user would (the Foxglove web build, the layout preloaded): first live, as the
episode runs and after it has ended, then its bag over HTTP.

Live (a run of its own, held at t = 0 until the page has subscribed: ``--wait-for-viewer``),
sim time advances on screen while the episode runs, every panel fills, and the final state
stays on screen after the episode (``--linger``). Seeked to a sim time, the bag's panels show
what it holds then: the robots where they are in their states' colours with a heading, the
sources, the arena centred, the recorded cue map, the three metric plots with a legend
value, the announcement and the status, no problems. A layout with wrong topic names fails
exactly those checks.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from checks import Expected, plots_of, settle
from conftest import LAYOUT
from foxapp import STATUS, FoxgloveApp, app_url
from shown import expected_at

from liverun import LEGACY_SUBPROTOCOL, SharedRun, accepts_legacy_subprotocol, held_embedded_run

pytestmark = [pytest.mark.slow]
#: Between two metric samples (1 s apart) and after the 150 s cue map: nothing on the edge.
SEEK = 150.5
#: examples/obstacle_layout.yaml's six pillars (r = 6 cm) alone (the wedge and the wall add).
PILLARS = 6 * np.pi * 0.06 ** 2


#: The live test's episode (sim seconds) and its pace (sim seconds per wall second): its start
#: waits for the page, so the page needs no slack, and a live page costs chromium more than a
#: core (WebGL in software) for as long as the episode runs: 20 s of wall time.
HELD, HELD_PACE = 200.0, 10.0


@pytest.fixture
def run(embedded_live: SharedRun) -> SharedRun:
    """The embedded runner's lingering live run (tests/liverun.py): N = 12, seed 2, 200 s at
    3 sim seconds per wall second, with a bag, among examples/obstacle_layout.yaml's
    obstacles (its bag is the one the tests below open)."""
    return embedded_live


@pytest.fixture
def held(tmp_path: Path) -> Iterator[SharedRun]:
    """A lingering embedded live run of its own for the live test (tests/liverun.py): N = 12,
    seed 2, 200 s at pace 10, among the same obstacles, held at t = 0 until the page has
    subscribed (``--wait-for-viewer``): however long the page takes to load, it then has the
    whole episode, about 20 s of wall time, to show a running status and a later one (the
    status panel's text is read once a second). The shared run starts at once, and on a busy
    2-core machine its episode had ended before a slow page had loaded and looked."""
    yield from held_embedded_run(tmp_path / 'held', HELD, HELD_PACE)


@pytest.fixture
def bag(run: SharedRun, data_dir: Path) -> Path:
    """The run's bag, served at /data/embedded/bag/bag.mcap, once the episode has ended."""
    run.wait_lingering()
    served = data_dir / 'embedded' / 'bag'
    if not served.exists():
        shutil.copytree(run.out / 'bag', served)
    return served


@pytest.fixture
def expected(bag: Path) -> Expected:
    return Expected(**{**expected_at(bag, SEEK, LAYOUT, 'embedded').__dict__,
                       'obstacle_area': PILLARS})


def test_the_live_view_shows_the_episode_and_keeps_it_after_the_end(browser, server, shots,
                                                                     held):
    run = held
    # The web build offers only the older subprotocol name; the live view must take it.
    assert accepts_legacy_subprotocol(run.url), LEGACY_SUBPROTOCOL
    live = Expected(population=run.population, seed=run.seed, mode='embedded',
                    plots=plots_of(LAYOUT), obstacle_area=PILLARS)
    app = FoxgloveApp(browser, shots)
    try:
        took = app.open(app_url(server.url, run.url))
        # The page has subscribed, so the episode runs: sim time advances on screen.
        first, later = app.sim_time_advances(run.duration)
        print(f'opened in {took:.1f} s; running at {first:g} s, then {later:g} s')
        run.run.wait_for('a viewer has subscribed; the episode starts', 10)
        view, found = settle(app, live)  # every panel fills (maybe only after the end)
        print(app.save('embedded_live'))
        assert found == []
        # The episode ends; the viewer keeps its final state on screen (no reconnect), also
        # when its window was minimised meanwhile (the page draws nothing then).
        with app.minimised():
            run.wait_lingering()
        app.page.wait_for_timeout(3000)
        final, found = settle(app, live, enough=lambda found: not found and
                              '"state": "finished"' in app.text(STATUS))
        print(app.save('embedded_live_after_the_end'))
    finally:
        app.close()
    assert found == []
    assert '"state": "finished"' in final.status_text
    assert final.status_time == run.duration


def test_the_layout_shows_an_embedded_bag(browser, server, shots, bag, expected):
    assert expected.states is not None  # the embedded runner records the states
    app = FoxgloveApp(browser, shots)
    try:
        took = app.open(app_url(server.url, f'{server.url}/data/embedded/bag/bag.mcap', SEEK))
        view, found = settle(app, expected)
        print(f'opened in {took:.1f} s; {app.save("embedded_bag")}')
    finally:
        app.close()
    assert found == []
    assert view.clock == pytest.approx(SEEK, abs=0.01)  # the seek landed where asked


def broken(layout: Path, folder: Path) -> Path:
    """The layout with one wrong topic name in each of four panels (as a typo would)."""
    data = json.loads(layout.read_text())
    config = data['configById']
    config['Plot!near']['paths'][0]['value'] = '/metrics/ratio_near_sorce.data'
    config['ImageViewPanel!cue']['cameraTopic'] = '/world/cue_mapp'
    config['RawMessages!status']['topicPath'] = '/world/statuss'
    script = data['userNodes']['mona-swarm-robots']
    script['sourceCode'] = script['sourceCode'].replace('"/world/poses", ', '"/world/pose", ')
    path = folder / 'broken_layout.json'
    path.write_text(json.dumps(data))
    return path


def test_a_layout_with_wrong_topic_names_fails_the_checks(browser, server, shots, bag, expected,
                                                          tmp_path):
    served = server.site.layout
    server.site.layout = broken(served, tmp_path)
    app = FoxgloveApp(browser, shots)
    try:
        app.open(app_url(server.url, f'{server.url}/data/embedded/bag/bag.mcap', SEEK))
        # Wait until the unbroken panels are right, so what fails is the broken names only.
        view, found = settle(app, expected, enough=lambda found: not any(
            'mean cue' in line or 'coherency' in line or 'announcement' in line
            for line in found))
        print(app.save('broken_layout'))
    finally:
        app.close()
        server.site.layout = served
    text = '\n'.join(found)
    assert "the plot 'ratio near source' draws no series" in text
    assert 'the cue map panel' in text
    assert 'the status panel does not show' in text
    assert 'the 3D panel' in text  # the robots' script has no input: nothing to draw
    # The panels named right still pass: the failures are the wrong names, not the app.
    assert not any('mean cue' in line or 'coherency' in line or 'announcement' in line
                   for line in found)
    assert 'No problems found' in view.problems  # a wrong name is no problem to the app

"""The shipped layout on an embedded run (`mona-swarm run --live --bag`), opened in a real
browser as a user would (the Foxglove web build, the layout preloaded): first live, as the
episode runs and after it has ended, then its bag over HTTP.

Live, every panel fills, sim time advances, and the final state stays on screen after the
episode (``--linger``). Seeked to a sim time, the bag's panels show what it holds then: the
robots where they are in their states' colours with a heading, the sources, the arena
centred, the recorded cue map, the three metric plots with a legend value, the announcement
and the status, no problems. A layout with wrong topic names fails exactly those checks.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from checks import Expected, plots_of, settle
from conftest import LAYOUT
from foxapp import STATUS, FoxgloveApp, app_url, status_seconds
from liverun import LEGACY_SUBPROTOCOL, LiveRun, accepts_legacy_subprotocol
from shown import expected_at

pytestmark = pytest.mark.slow
POPULATION, DURATION, SEED = 12, 200.0, 2
#: Sim seconds per wall second: the episode lasts about 67 s, long enough for the page to
#: load and look while it runs on a busy 2-core machine.
PACE = 3.0
#: Between two metric samples (1 s apart) and after the 150 s cue map: nothing on the edge.
SEEK = 150.5
MONA_SWARM = Path(sys.executable).parent / 'mona-swarm'


@pytest.fixture(scope='module')
def run(data_dir: Path) -> Iterator[LiveRun]:
    """The paced episode with its live view and bag (``data_dir/embedded``), lingering after
    the episode until the module is done (then Ctrl-C)."""
    live = LiveRun([str(MONA_SWARM), 'run', '--population', str(POPULATION), '--seed',
                    str(SEED), '--duration', str(DURATION), '--out',
                    str(data_dir / 'embedded'), '--bag', '--live', '--live-port', '0', '--pace',
                    str(PACE), '--linger', '900'])
    live.url = live.wait_for('live view on ws://', 120).split('live view on ')[1].split()[0]
    try:
        yield live
    finally:
        status = live.stop()
    assert status == 0, live.output[-3000:]


def episode_ended(run: LiveRun, timeout: float = 300.0) -> None:
    """Until the episode's outputs are written (then the run lingers)."""
    run.wait_for('the episode has ended', timeout)


@pytest.fixture(scope='module')
def bag(run: LiveRun, data_dir: Path) -> Path:
    """The run's bag, served at /data/embedded/bag/bag.mcap, once the episode has ended."""
    episode_ended(run)
    return data_dir / 'embedded' / 'bag'


@pytest.fixture(scope='module')
def expected(bag: Path) -> Expected:
    return expected_at(bag, SEEK, LAYOUT, 'embedded')


def test_the_live_view_shows_the_episode_and_keeps_it_after_the_end(browser, server, shots,
                                                                     run):
    # The web build offers only the older subprotocol name; the live view must take it.
    assert accepts_legacy_subprotocol(run.url), LEGACY_SUBPROTOCOL
    live = Expected(population=POPULATION, seed=SEED, mode='embedded', plots=plots_of(LAYOUT))
    app = FoxgloveApp(browser, shots)
    try:
        took = app.open(app_url(server.url, run.url))
        view, found = settle(app, live)
        # Sim time advances: a later status on screen within 30 s.
        later = app.wait_until(lambda: (status_seconds(app.text(STATUS)) or 0) >
                               (view.status_time or DURATION) and
                               status_seconds(app.text(STATUS)), 'a later status', 30)
        print(f'opened in {took:.1f} s; {app.save("embedded_live")}')
        assert found == []
        assert '"state": "running"' in view.status_text  # looked at while it ran
        assert view.status_time is not None and view.status_time < later <= DURATION
        # The episode ends; the viewer keeps its final state on screen (no reconnect).
        episode_ended(run)
        app.page.wait_for_timeout(3000)
        final, found = settle(app, live, enough=lambda found: not found and
                              '"state": "finished"' in app.text(STATUS))
        print(app.save('embedded_live_after_the_end'))
    finally:
        app.close()
    assert found == []
    assert '"state": "finished"' in final.status_text
    assert final.status_time == DURATION


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

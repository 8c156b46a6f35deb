"""The shipped layout on an embedded run's bag (`mona-swarm run --bag`), opened in a real
browser as a user would: the Foxglove web build, the bag over HTTP, the layout preloaded.

Seeked to a sim time, every panel must show what the bag holds then: the robots where they
are in their states' colours with a heading, the arena centred, the recorded cue map, the
three metric plots with a legend value, the announcement and the status, no problems. A
layout with wrong topic names must fail exactly those checks.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from checks import Expected, findings, settle
from conftest import LAYOUT
from foxapp import FoxgloveApp, app_url
from shown import expected_at

pytestmark = pytest.mark.slow
POPULATION, DURATION, SEED = 12, 200.0, 2
#: Between two metric samples (1 s apart) and after the 150 s cue map: nothing on the edge.
SEEK = 150.5
MONA_SWARM = Path(sys.executable).parent / 'mona-swarm'


@pytest.fixture(scope='module')
def bag(data_dir: Path) -> Path:
    """An embedded episode's bag, served at /data/embedded/bag/bag.mcap."""
    out = data_dir / 'embedded'
    subprocess.run([str(MONA_SWARM), 'run', '--population', str(POPULATION), '--seed',
                    str(SEED), '--duration', str(DURATION), '--out', str(out), '--bag'],
                   check=True, timeout=300, capture_output=True)
    return out / 'bag'


@pytest.fixture(scope='module')
def expected(bag: Path) -> Expected:
    return expected_at(bag, SEEK, LAYOUT, 'embedded')


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
    assert findings(view, expected) == found

"""The Foxglove layout shipped in ros_ws/config: valid JSON, a whole panel tree, and only
topics that the bags and the live view carry."""

from __future__ import annotations

import json
from pathlib import Path

from mona_controller.topics import TOPICS as CONTRACT
from mona_controller.topics import metric_topic
from swarm_metrics.metrics import PAPER_METRICS, plotted
from swarm_supervisor.media.live import LIVE_TOPICS
from swarm_supervisor.outputs.bag import TOPICS

LAYOUT = Path(__file__).parents[2] / 'ros_ws' / 'config' / 'foxglove_layout.json'
#: Topics only the live view carries (a bag records them only with record_all): the 3D
#: panel's cue grid and robot markers; docs/bags.md says so.
LIVE_ONLY = {name for name, topic in CONTRACT.items() if topic.live and not topic.recorded}


def panels(tree) -> list[str]:
    """The panel ids of a layout tree (a panel id, or a split of two subtrees)."""
    if isinstance(tree, str):
        return [tree]
    assert tree['direction'] in ('row', 'column')
    return panels(tree['first']) + panels(tree['second'])


def topics_named(config: dict) -> dict[str, set[str]]:
    """Panel id -> the topics its configuration names."""
    named: dict[str, set[str]] = {}
    for panel, settings in config.items():
        topics = set(settings.get('topics', {}))
        topics |= {settings[key] for key in ('topicPath',) if key in settings}
        if 'imageTopic' in settings.get('imageMode', {}):
            topics.add(settings['imageMode']['imageTopic'])
        topics |= {path['value'].split('.')[0] for path in settings.get('paths', [])}
        named[panel] = topics
    return named


def test_the_layout_is_valid_json_with_a_whole_panel_tree():
    layout = json.loads(LAYOUT.read_text())
    config = layout['configById']
    tree = panels(layout['layout'])
    assert sorted(tree) == sorted(config)  # every panel placed once, none missing
    kinds = {panel.split('!')[0] for panel in tree}
    assert {'3D', 'Image', 'Plot', 'RawMessages'} <= kinds
    assert config['3D!arena']['followTf'] == 'world'  # the frame every world topic uses


def test_the_layout_names_only_topics_the_bags_and_the_live_view_carry():
    named = topics_named(json.loads(LAYOUT.read_text())['configById'])
    everything = set().union(*named.values())
    assert everything <= set(LIVE_TOPICS)
    assert everything - LIVE_ONLY <= set(TOPICS)
    assert LIVE_ONLY <= set(LIVE_TOPICS) and not LIVE_ONLY & set(TOPICS)
    # The paper's plotted metrics (the entries with a plot label) are plotted, the
    # announcement and the status shown, the arena's robots, obstacles and cue drawn: from a
    # bag (poses, obstacles, cue map) and live (markers, grid).
    shown = set().union(*(t for p, t in named.items() if p.startswith('Plot')))
    assert shown == {metric_topic(name) for name, _ in plotted() if name in PAPER_METRICS}
    assert shown == {'/metrics/mean_cue_fraction', '/metrics/ratio_near_source',
                     '/metrics/coherency'}
    assert {'/episode', '/world/status'} <= everything
    assert named['3D!arena'] == {'/world/poses', '/world/cue_grid', '/world/markers',
                                 '/world/obstacles'}
    assert named['Image!cue'] == {'/world/cue_map'}

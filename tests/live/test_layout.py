"""The Foxglove layout shipped in ros_ws/config: valid JSON, a whole panel tree, and only
topics that the bags and the live view carry (tests/browser/ opens it in the real app)."""

from __future__ import annotations

import json
import re
from pathlib import Path

from mona_controller.controllers.beeclust import STATES as BEECLUST_STATES
from mona_controller.topics import TOPICS as CONTRACT
from mona_controller.topics import metric_topic
from swarm_metrics.metrics import PAPER_METRICS, plotted
from swarm_supervisor.media.live import LIVE_TOPICS
from swarm_supervisor.outputs.bag import TOPICS
from swarm_world.arena_markers import SOURCE_COLOUR

LAYOUT = Path(__file__).parents[2] / 'ros_ws' / 'config' / 'foxglove_layout.json'
#: Topics only the live view carries (a bag records them only with record_all): the 3D
#: panel's cue grid and robot markers; docs/bags.md says so.
LIVE_ONLY = {name for name, topic in CONTRACT.items() if topic.live and not topic.recorded}
#: Topics the app's user scripts publish (inside the app, from the scripts' inputs).
SCRIPT_PREFIX = '/studio_script/'


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
        topics = {topic for topic, shown in settings.get('topics', {}).items()
                  if shown.get('visible')}
        topics |= {settings[key] for key in ('topicPath', 'cameraTopic') if key in settings}
        if 'imageTopic' in settings.get('imageMode', {}):
            topics.add(settings['imageMode']['imageTopic'])
        topics |= {path['value'].split('.')[0] for path in settings.get('paths', [])}
        named[panel] = topics
    return named


def script_topics(source: str) -> tuple[list[str], str]:
    """A user script's ``(inputs, output)``, as the app reads them from its source."""
    inputs = re.search(r'^export const inputs = \[([^\]]*)\];', source, re.M)
    output = re.search(r'^export const output = "([^"]+)";', source, re.M)
    assert inputs and output, 'a user script without inputs or output'
    return re.findall(r'"([^"]+)"', inputs.group(1)), output.group(1)


def test_the_layout_is_valid_json_with_a_whole_panel_tree():
    layout = json.loads(LAYOUT.read_text())
    config = layout['configById']
    tree = panels(layout['layout'])
    assert sorted(tree) == sorted(config)  # every panel placed once, none missing
    kinds = {panel.split('!')[0] for panel in tree}
    # The older image view panel: the app's new 'Image' panel is a stub in the web build.
    assert {'3D', 'ImageViewPanel', 'Plot', 'RawMessages'} <= kinds and 'Image' not in kinds
    assert config['3D!arena']['followTf'] == 'world'  # the frame every world topic uses


def test_the_camera_centres_the_arena_top_down():
    """The app's camera centres on ``targetOffset`` (its ``target`` is not where it looks)."""
    scene = json.loads(LAYOUT.read_text())['configById']['3D!arena']
    camera, arena = scene['cameraState'], scene['layers']['arena']
    side = arena['size']
    assert camera['targetOffset'] == [side / 2, side / 2, 0] == arena['position']
    assert camera['target'] == [0, 0, 0]
    assert camera['phi'] == 0 and camera['perspective'] is False  # straight down
    assert side < camera['distance'] < 1.3 * side  # the arena fills most of the panel


def test_the_layout_names_only_topics_the_bags_and_the_live_view_carry():
    layout = json.loads(LAYOUT.read_text())
    named = topics_named(layout['configById'])
    scripts = [script_topics(node['sourceCode']) for node in layout['userNodes'].values()]
    outputs = {output for _, output in scripts}
    assert all(output.startswith(SCRIPT_PREFIX) for output in outputs)
    everything = set().union(*named.values(), *(inputs for inputs, _ in scripts)) - outputs
    assert everything <= set(LIVE_TOPICS)
    assert everything - LIVE_ONLY <= set(TOPICS)
    assert LIVE_ONLY <= set(LIVE_TOPICS) and not LIVE_ONLY & set(TOPICS)
    # The paper's plotted metrics (the entries with a plot label) are plotted, the
    # announcement and the status shown, the arena's robots (by the script, from the poses
    # and the states), obstacles and cue drawn: the cue map from a bag, the grid live.
    shown = set().union(*(t for p, t in named.items() if p.startswith('Plot')))
    assert shown == {metric_topic(name) for name, _ in plotted() if name in PAPER_METRICS}
    assert shown == {'/metrics/mean_cue_fraction', '/metrics/ratio_near_source',
                     '/metrics/coherency'}
    assert {'/episode', '/world/status'} <= everything
    assert scripts == [(['/episode', '/world/poses', '/world/robot_states'],
                        '/studio_script/robots')]
    assert named['3D!arena'] == {'/studio_script/robots', '/world/cue_grid',
                                 '/world/obstacles', '/world/sources'}
    assert named['ImageViewPanel!cue'] == {'/world/cue_map'}


def test_the_robots_script_takes_the_announced_states_and_falls_back_to_beeclusts():
    """The script colours robots by the states /episode announces (any kind's); a bag from
    before the kinds announced them gets BEECLUST's colours, the very ones the kind
    declares."""
    (node,) = json.loads(LAYOUT.read_text())['userNodes'].values()
    source = node['sourceCode']
    assert 'announced.states' in source and 'palette[state] ?? NO_STATE' in source
    block = re.search(r'const BEECLUST: Colour\[\] = \[(.*?)\];', source, re.S).group(1)
    colours = [tuple(float(v) for v in re.findall(r'[rgba]: ([\d.]+)', row))
               for row in re.findall(r'\{[^}]*\}', block)]
    assert colours == [state.colour for state in BEECLUST_STATES]


def test_robots_obstacles_and_outline_have_colours_seen_on_any_cue():
    """The cue grid runs from a dark clean floor to light grey; the outline (yellow) and the
    obstacles (cyan) are saturated colours off that ramp, as the sources' own magenta is."""
    scene = json.loads(LAYOUT.read_text())['configById']['3D!arena']
    grid = scene['topics']['/world/cue_grid']
    assert grid['colorMode'] == 'custom'
    ends = [grid['minColor'], grid['maxColor']]
    outline, obstacles = scene['layers']['arena'], scene['topics']['/world/obstacles']
    for colour in (outline['color'], obstacles['color']):
        channels = [int(colour[i:i + 2], 16) for i in (1, 3, 5)]
        assert max(channels) - min(channels) >= 180, colour  # saturated: not on the grey ramp
        assert colour not in ends
    source = [round(255 * c) for c in SOURCE_COLOUR[:3]]
    assert max(source) - min(source) >= 180
    for end in ends:
        channels = [int(end[i:i + 2], 16) for i in (1, 3, 5)]
        assert max(channels) - min(channels) <= 10, end  # the ramp itself is grey

"""Every static picture of the arena draws its obstacles, as the videos and Foxglove do: an
episode's final_cue_map.png and the report's fig. 3."""

from __future__ import annotations

import numpy as np
from PIL import Image

from swarm_supervisor.analysis.figures import fig3_cue_maps
from swarm_supervisor.config import load_config
from swarm_supervisor.outputs.pictures import save_cue_map
from swarm_world.field import initial_cue
from swarm_world.messages.markers import COLOUR

LAYOUT = {'box': [1.0, 1.0, 1.4, 1.4], 'pillar': [2.0, 0.6, 0.2]}
FILL = np.array([round(c * 255) for c in COLOUR[:3]])


def _filled(path) -> int:
    """The pixels of the picture in the obstacles' grey."""
    pixels = np.asarray(Image.open(path).convert('RGB')).astype(int)
    return int((np.abs(pixels - FILL).max(axis=2) <= 1).sum())


def test_the_final_cue_map_and_fig3_draw_the_obstacles(tmp_path):
    world = load_config().replace(world={'obstacles': LAYOUT}).world
    cue = initial_cue(world)
    poses = np.array([[0.5, 0.5, 0.0], [2.5, 2.5, 1.0]])
    counts = {}
    for name, obstacles in (('with', world.arena().obstacles), ('without', ())):
        save_cue_map(tmp_path / f'{name}.png', cue, poses, world.arena_side, 0.04,
                     obstacles=obstacles)
        snapshots = {'times': np.array([0.0, 1000.0, 4000.0]), 'cue': np.stack([cue] * 3),
                     'poses': np.stack([poses] * 3)}
        fig3_cue_maps(snapshots, tmp_path / f'fig3_{name}.png', population=2, speed=0.08,
                      seed=1, arena_side=world.arena_side, body_radius=0.04, peak=255.0,
                      duration=4000.0, obstacles=obstacles)
        counts[name] = (_filled(tmp_path / f'{name}.png'), _filled(tmp_path / f'fig3_{name}.png'))
    # the box and the pillar in every picture (a few anti-aliased pixels of text are grey too)
    assert all(w - wo > 1000 for w, wo in zip(counts['with'], counts['without']))

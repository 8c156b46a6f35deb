"""What a bag holds at a sim time, as the app shows it after seeking there: the latest message
of each topic at or before that time (read with the project's own strict bag reader)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from checks import Expected, plots_of

from swarm_metrics.bags.reader import cue_of, decode, find_mcap, poses_of
from swarm_metrics.bags.scan import McapScan
from swarm_world.messages.cdr import states_from_cdr
from swarm_world.messages.markers import sources_from_markers


def latest(bag: Path, topic: str, at_ns: int):
    """The last message on ``topic`` logged at or before ``at_ns`` (None if there is none)."""
    found = None
    for message in McapScan(find_mcap(bag)):
        if message.topic == topic and message.log_time <= at_ns:
            found = message
    return found


def expected_at(bag: Path, at_s: float, layout: Path, mode: str) -> Expected:
    """What the layout should show of ``bag`` seeked to ``at_s`` sim seconds."""
    at_ns = round(at_s * 1e9)
    poses = poses_of(decode(latest(bag, '/world/poses', at_ns)))
    states = latest(bag, '/world/robot_states', at_ns)
    image = cue_of(decode(latest(bag, '/world/cue_map', at_ns)))[::-1]  # as drawn: max y on top
    announcement = decode(latest(bag, '/episode', at_ns))
    announced = json.loads(announcement.data)
    sources = sources_from_markers(decode(latest(bag, '/world/sources', at_ns)).markers)
    return Expected(population=len(poses), seed=int(announced['seed']), mode=mode,
                    plots=plots_of(layout), positions=poses[:, :2], cue=image,
                    states=None if states is None else states_from_cdr(states.data),
                    sources=np.array([(x, y) for _, x, y in sources]).reshape(-1, 2))


"""Test helpers: episode bags made from the embedded engine, serialized as the world node does.

``python bagtools.py BAG SECONDS`` writes an endless synthetic stream into BAG and prints each
log time it wrote (flushed), for the SIGKILL test.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from swarm_metrics.bags.writer import EpisodeBagWriter, offered_qos
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode
from swarm_world.messages.cdr import TYPESTORE, sources_cdr, states_cdr
from swarm_world.timing import crossed

TYPES = TYPESTORE.types
STRING, FLOAT64 = 'std_msgs/msg/String', 'std_msgs/msg/Float64'
POSE_ARRAY, IMAGE = 'geometry_msgs/msg/PoseArray', 'sensor_msgs/msg/Image'
METRICS = ('mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency')
TOPICS = {'/episode': (STRING, offered_qos(1, latched=True)),
          '/world/status': (STRING, offered_qos(1, latched=True)),
          '/world/poses': (POSE_ARRAY, offered_qos(10)),
          '/world/cleaning': (POSE_ARRAY, offered_qos(100)),
          '/world/cue_map': (IMAGE, offered_qos(1, latched=True)),
          '/world/robot_states': ('std_msgs/msg/UInt8MultiArray', offered_qos(1000)),
          '/world/sources': ('visualization_msgs/msg/MarkerArray', offered_qos(1, latched=True)),
          **{f'/metrics/{name}': (FLOAT64, offered_qos(10)) for name in METRICS}}


def header(ns: int, frame: str = 'world'):
    return TYPES['std_msgs/msg/Header'](
        stamp=TYPES['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9),
        frame_id=frame)


def string_cdr(text: str) -> bytes:
    return bytes(TYPESTORE.serialize_cdr(TYPES[STRING](data=text), STRING))


def float_cdr(value: float) -> bytes:
    return bytes(TYPESTORE.serialize_cdr(TYPES[FLOAT64](data=float(value)), FLOAT64))


def pose_array_cdr(poses: np.ndarray, ns: int) -> bytes:
    """[N, 3] poses as the world node sends them (yaw as a z-axis quaternion)."""
    pose, point, quaternion = (TYPES[f'geometry_msgs/msg/{name}']
                               for name in ('Pose', 'Point', 'Quaternion'))
    msg = TYPES[POSE_ARRAY](header=header(ns), poses=[
        pose(position=point(x=float(x), y=float(y), z=0.0),
             orientation=quaternion(x=0.0, y=0.0, z=math.sin(a / 2), w=math.cos(a / 2)))
        for x, y, a in np.asarray(poses).tolist()])
    return bytes(TYPESTORE.serialize_cdr(msg, POSE_ARRAY))


def image_cdr(cue: np.ndarray, ns: int) -> bytes:
    """The cue as /world/cue_map (mono8, row 0 at the top)."""
    rows, cols = cue.shape
    data = np.clip(np.rint(cue), 0, 255).astype(np.uint8)[::-1].ravel()
    msg = TYPES[IMAGE](header=header(ns), height=rows, width=cols, encoding='mono8',
                       is_bigendian=0, step=cols, data=data)
    return bytes(TYPESTORE.serialize_cdr(msg, IMAGE))


def announcement(config: SwarmConfig, poses: np.ndarray, start_ns: int,
                 episode: int = 0) -> dict:
    """The supervisor's /episode message for ``config``."""
    return {'episode': episode, 'seed': config.episode.seed,
            'population': config.episode.population, 'duration': config.episode.duration,
            'start_ns': start_ns, 'poses': np.asarray(poses).tolist(),
            'parameters': config.to_dict()}


def finished_status(config: SwarmConfig, steps: int, time_ns: int,
                    cleaning_events: int = 0) -> dict:
    """The world node's last /world/status of episode 0 (lockstep, nothing missed)."""
    return {'episode': 0, 'state': 'finished', 'step': steps, 'steps': steps,
            'time_ns': time_ns, 'mode': 'lockstep', 'misses': [0] * config.episode.population,
            'absent': [], 'dropped': 0, 'duplicates': 0, 'cleaning_events': cleaning_events,
            'error': None}


def embedded_episode_bag(path: Path, config: SwarmConfig, *, start_ns: int = 7 * 10**9,
                         all_poses: bool = False, map_period: float = 2.0,
                         chunk_period: float = 5.0,
                         drop: Callable[[str, int], bool] | None = None,
                         finished: bool = True) -> list[dict]:
    """Run one embedded episode and record it as the metrics node would; return its rows.

    The rows are the embedded runner's samples, also recorded on /metrics/* ('online').

    Args:
        drop: ``drop(topic, log_ns)`` true leaves that message out of the bag (a damaged
            record: missing seconds, a gap, a lost cleaning event); the rows are unchanged.
        finished: end with the world's ``finished`` /world/status, as the world node does.
    """
    episode = Episode(config)
    world = episode.world
    map_ns = round(map_period * 1e9)
    rows = [episode.metrics()]
    with EpisodeBagWriter(path, chunk_period=chunk_period) as bag:
        def write(topic: str, log_ns: int, data: bytes) -> None:
            if drop is None or not drop(topic, log_ns):
                bag.write(topic, log_ns, data)

        for topic, (msgtype, qos) in TOPICS.items():
            bag.add_topic(topic, msgtype, [qos])
        announced = announcement(config, world.poses, start_ns)
        bag.describe(announced)
        write('/episode', start_ns, string_cdr(json.dumps(announced)))
        def cue_map(ns: int) -> None:  # with the sources where they are
            write('/world/cue_map', ns, image_cdr(world.cue, ns))
            write('/world/sources', ns, sources_cdr(
                world.field.names, world.field.source_positions(world.time_ns / 1e9), ns))

        cue_map(start_ns)
        write('/world/robot_states', start_ns, states_cdr(episode.controllers.state))
        for name in METRICS:
            write(f'/metrics/{name}', start_ns, float_cdr(rows[0][name]))
        cleaning_events = 0
        while not episode.done:
            step = episode.step()
            now = start_ns + step.time_ns
            if len(step.cleaned):
                write('/world/cleaning', now, pose_array_cdr(world.poses[step.cleaned], now))
                cleaning_events += 1
            if step.sampled or all_poses:
                write('/world/poses', now, pose_array_cdr(world.poses, now))
            if step.sampled:
                write('/world/robot_states', now, states_cdr(episode.controllers.state))
            if step.sampled:
                rows.append(episode.metrics())
                for name in METRICS:
                    write(f'/metrics/{name}',
                          start_ns + step.time_ns // episode.sample_ns * episode.sample_ns,
                          float_cdr(rows[-1][name]))
                write('/world/status', now, string_cdr(json.dumps(
                    {'episode': 0, 'state': 'running', 'time_ns': now,
                     'cleaning_events': cleaning_events})))
            if crossed(step.before_ns, step.time_ns, map_ns):
                cue_map(now)
        if finished:
            end = start_ns + world.time_ns
            if not crossed(world.time_ns - 1, world.time_ns, map_ns):
                cue_map(end)  # the world's last map
            write('/world/status', end, string_cdr(json.dumps(
                finished_status(config, config.steps(), end, cleaning_events))))
    return rows


def endless_stream(path: Path, chunk_period: float) -> None:
    """Write 10 Hz poses + metrics forever, printing each log time once written."""
    config = SwarmConfig().replace(episode={'population': 3})
    poses = np.array([[0.5, 0.5, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]])
    with EpisodeBagWriter(path, chunk_period=chunk_period) as bag:
        for topic, (msgtype, qos) in TOPICS.items():
            bag.add_topic(topic, msgtype, [qos])
        announced = announcement(config, poses, 0)
        bag.describe(announced)
        bag.write('/episode', 0, string_cdr(json.dumps(announced)))
        bag.flush()
        k = 0
        while True:
            k += 1
            ns = k * 100_000_000
            bag.write('/world/poses', ns, pose_array_cdr(poses + k * 1e-4, ns))
            bag.write('/metrics/mean_cue', ns, float_cdr(k))
            print(ns, flush=True)


if __name__ == '__main__':
    endless_stream(Path(sys.argv[1]), float(sys.argv[2]))

"""``mona-swarm analyze``, ``replay`` and ``recover``: working with episode bags.

A bag the writer never closed (a killed node) is recovered automatically by ``analyze`` and
``replay`` into ``<bag>_recovered``. A bad bag gets a one-paragraph report and exit status 2.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
import time
from pathlib import Path

from mona_controller.schema import ParameterError, from_mapping
from swarm_metrics.analysis import episode_setup, recompute
from swarm_metrics.bag_reader import BagError, McapScan, find_mcap, read_episode_bag
from swarm_metrics.recover import SUFFIX, recover_bag, with_recovery
from swarm_supervisor.arguments import bounded
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.outputs import EPISODE_FILE, write_episode
from swarm_supervisor.runner import EpisodeResult

BAG_NAMES = ('bag', 'bag' + SUFFIX)  # the metrics node's bag folder (and its recovered copy)


def register(subparsers) -> None:
    """Add the ``analyze``, ``replay`` and ``recover`` subcommands."""
    parser = subparsers.add_parser(
        'analyze', help='recompute the metrics of episode bags',
        description='Recompute every metric from episode bags (rosbag2 directories or .mcap '
                    'files) and write metrics.csv, episode.json, snapshots.npz and a final cue '
                    'map PNG per bag, like `mona-swarm run`. A bag whose writer was killed is '
                    'recovered first.')
    parser.add_argument('bags', nargs='+', type=Path, metavar='BAG')
    parser.add_argument('--out', type=Path, metavar='DIR',
                        help='output folder (with several bags: one subfolder each); default: '
                             'the folder holding each bag (episode_<k>/)')
    parser.set_defaults(handler=analyze)

    parser = subparsers.add_parser(
        'replay', help='play a bag back onto its ROS topics',
        description='Publish every message of a bag on its topic, with /clock, timed by the '
                    'log (sim) times divided by --rate.')
    parser.add_argument('bag', type=Path, metavar='BAG')
    parser.add_argument('--rate', type=bounded(float, 0), default=1.0,
                        help='sim seconds per wall second (default 1; 0: as fast as possible)')
    parser.add_argument('--delay', type=bounded(float, 0), default=1.0, metavar='SECONDS',
                        help='wait this long for subscribers to connect before playing '
                             '(default 1)')
    parser.set_defaults(handler=replay)

    parser = subparsers.add_parser(
        'recover', help='salvage a bag whose writer was killed',
        description='Rewrite every intact message of a bag (e.g. one without its MCAP '
                    'summary after a crash) as a valid bag, and report what was kept.')
    parser.add_argument('bag', type=Path, metavar='BAG')
    parser.add_argument('--out', type=Path, metavar='DIR',
                        help=f'the recovered bag (default: <BAG>{SUFFIX})')
    parser.set_defaults(handler=recover)


def _bad_bag(command: str, error: Exception) -> int:
    print(f'mona-swarm {command}: error: {error}', file=sys.stderr)
    return 2


# --- analyze ------------------------------------------------------------------------------

def bag_directory(path: Path) -> Path:
    """The bag itself: its rosbag2 directory, or a lone .mcap file."""
    path = path.resolve()
    if path.suffix == '.mcap' and path.parent.name == path.stem:
        return path.parent  # rosbags' layout: <dir>/<dir>.mcap
    return path


def output_folder(path: Path, out: Path | None, several: bool) -> Path:
    """Where a bag's analysis goes: next to the bag (the episode_<k>/ folder holding it), or
    ``out``, or with several bags a subfolder of ``out`` named after the episode or bag."""
    bag = bag_directory(path)
    if out is None:
        return bag.parent
    if not several:
        return out
    return out / (bag.parent.name if bag.name.startswith(BAG_NAMES) else bag.stem)


def analyze(args: argparse.Namespace) -> int:
    """Recompute and write each bag's outputs; a bad bag is reported and skipped."""
    failed = 0
    for path in args.bags:
        out = output_folder(path, args.out, len(args.bags) > 1)
        try:
            message = analyze_bag(path, out)
        except BagError as error:
            failed += 1
            _bad_bag('analyze', error)
            continue
        print(message)
    return 2 if failed else 0


def analyze_bag(path: Path, out: Path) -> str:
    """Recompute one bag into ``out``; returns the line to print."""
    bag, note = with_recovery(path, read_episode_bag)
    try:
        config = from_mapping(SwarmConfig, episode_setup(bag).parameters)
    except ParameterError as error:
        raise BagError(f'{bag.path}: the announced parameters are invalid: {error}') from None
    duration = config.episode.duration
    started = time.perf_counter()
    result = recompute(bag, snapshot_times=config.study.snapshot_times + (duration,))
    setup = result.setup
    steps = (result.last_status or {}).get('step')
    episode = EpisodeResult(
        config=config, metrics=result.rows, initial_poses=setup.initial_poses,
        final_poses=result.final_poses, final_cue=result.final_cue,
        snapshots=result.snapshots, encounters=-1,
        steps=steps if isinstance(steps, int) else round(result.covered
                                                         / config.world.step_period),
        wall_time=time.perf_counter() - started)
    write_episode(episode, out)
    # Replace the embedded runner's record with what a bag can tell.
    record = json.loads((out / EPISODE_FILE).read_text())
    for key in ('encounters', 'wall_time_s', 'real_time_factor'):
        record.pop(key, None)
    status = result.last_status or {}
    record.update(
        runner='ros', episode=setup.episode, bag=str(bag.path), recovered=note is not None,
        sim_time_covered=result.covered, complete=result.complete,
        online_metrics={'samples': result.online_rows, 'max_abs_diff': result.online_max_diff},
        cue_maps={'checked': result.cue_maps_checked, 'max_abs_diff': result.cue_map_max_diff},
        world={key: status.get(key) for key in ('state', 'steps', 'misses', 'dropped')})
    temporary = out / (EPISODE_FILE + '.tmp')
    temporary.write_text(json.dumps(record, indent=2) + '\n')
    os.replace(temporary, out / EPISODE_FILE)
    last = result.rows[-1]
    agreement = ('no online metrics in the bag' if result.online_max_diff is None else
                 f'online metrics agree to {result.online_max_diff:.3g}')
    text = (f'{out}: N={setup.population} seed={setup.seed}: mean cue {last["mean_cue"]:.2f} '
            f'({last["mean_cue_fraction"]:.1%} of start) after {last["t"]:g} s'
            f'{"" if result.complete else f" (INCOMPLETE: episode is {duration:g} s)"}; '
            f'{agreement}; {result.cue_maps_checked} cue maps match the rebuilt cue to '
            f'{result.cue_map_max_diff}')
    return text + (f'\n  note: {note}' if note else '')


# --- recover ------------------------------------------------------------------------------

def recover(args: argparse.Namespace) -> int:
    """Salvage a bag and report what was kept."""
    try:
        report = recover_bag(args.bag, args.out)
    except BagError as error:
        return _bad_bag('recover', error)
    print(report.summary())
    return 0


# --- replay -------------------------------------------------------------------------------

def checked_mcap(path: Path) -> tuple[Path, dict[str, str]]:
    """The bag's .mcap after a full strict read, and its topics -> types."""
    scan = McapScan(find_mcap(path))
    for _ in scan:
        pass
    return scan.path, {topic.topic: topic.msgtype for topic in scan.topics.values()}


def replay(args: argparse.Namespace) -> int:
    """Publish the bag's messages on their topics, timed by their log times."""
    try:
        (mcap, topics), note = with_recovery(args.bag, checked_mcap)
    except BagError as error:
        return _bad_bag('replay', error)
    if note:
        print(f'note: {note}', file=sys.stderr)
    import rclpy  # only replay needs ROS
    from builtin_interfaces.msg import Time
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock

    from mona_controller import qos

    profiles = {qos.CLOCK: qos.CLOCK_QOS, qos.EPISODE: qos.EPISODE_QOS,
                qos.STATUS: qos.STATUS_QOS, qos.POSES: qos.POSES_QOS,
                qos.CLEANING: qos.CLEANING_QOS, qos.CUE_MAP: qos.MAP_QOS,
                qos.CUE_GRID: qos.MAP_QOS, qos.MARKERS: qos.MARKERS_QOS}
    per_robot = {qos.GROUND: qos.SENSOR_QOS, qos.PROXIMITY: qos.SENSOR_QOS,
                 qos.CMD_VEL: qos.COMMAND_QOS, qos.CLEANER: qos.CLEANER_QOS}
    rclpy.init()
    node = None
    try:
        node = rclpy.create_node('replay')
        publishers, skipped = {}, []
        for topic, msgtype in sorted(topics.items()):
            try:
                package, _, name = msgtype.split('/')
                msg_class = getattr(importlib.import_module(f'{package}.msg'), name)
            except (ValueError, ImportError, AttributeError):
                skipped.append(topic)
                continue
            profile = profiles.get(topic) or per_robot.get(topic.rsplit('/', 1)[-1]) \
                or QoSProfile(depth=10)
            publishers[topic] = node.create_publisher(msg_class, topic, profile)
        clock = None if qos.CLOCK in publishers else node.create_publisher(
            Clock, qos.CLOCK, qos.CLOCK_QOS)
        if skipped:
            print(f'note: not replaying {", ".join(skipped)} (message types not installed)',
                  file=sys.stderr)
        time.sleep(args.delay)
        count, first, last, clock_ns = 0, None, None, -1
        started = time.monotonic()
        for message in McapScan(mcap):
            publisher = publishers.get(message.topic)
            if publisher is None:
                continue
            first = message.log_time if first is None else first
            last = message.log_time if last is None else max(last, message.log_time)
            if args.rate > 0:
                wait = started + (message.log_time - first) / 1e9 / args.rate - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
            if clock is not None and message.log_time > clock_ns:
                clock_ns = message.log_time
                clock.publish(Clock(clock=Time(sec=clock_ns // 10**9,
                                               nanosec=clock_ns % 10**9)))
            publisher.publish(message.data)
            count += 1
        span = 0.0 if first is None else (last - first) / 1e9
        print(f'replayed {count} messages on {len(publishers)} topics from {mcap}: {span:.3f} '
              f's of sim time in {time.monotonic() - started:.1f} s')
        return 0
    except BagError as error:
        return _bad_bag('replay', error)
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()

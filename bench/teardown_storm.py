"""Experiment: many rclpy processes leave at the same moment; how many hang in teardown?

The end of ``scripts/swarm.sh --population 50`` in miniature, without the model: K controller
processes (one node each in ``/mona_<i>``: ground and proximity subscribed, cmd_vel and cleaner
published, /clock and /episode subscribed, parameter services, as the real controller) and one
world process (the other end of every per-robot topic, publishing readings at 5 Hz, each
controller answering), all in a private ROS domain with the project's Fast DDS profile
(tests/harness.py). Once every process has matched its peers and sees all K + 1 nodes, the
parent creates a start file that every process polls; each then tears down with the variant
under test at the same moment. The parent times each exit from the start file and reads the
logs: a process whose watchdog fired printed faulthandler's ``Timeout (...)!`` and where it
hung.

Variants (``--variants``, several per run, interleaved round by round):

- ``legacy``: the teardown() before the fix: destroy the nodes, ``rclpy.try_shutdown()``,
  under ``faulthandler.dump_traceback_later(timeout, exit=True)`` (a hang exits 1).
- ``shutdown-first``: ``rclpy.try_shutdown()`` before destroying the nodes, same watchdog.
- ``entities-first``: every publisher, subscription, service and timer destroyed one by one,
  the executor shut down, then the node, then the context, same watchdog.
- ``no-destroy``: flush stdout and stderr, ``os._exit(0)``: no DDS entity is destroyed.
- ``repo``: ``mona_controller.ros.shutdown.teardown(nodes, timeout, exit_status=0)`` as it is in
  the working tree (the fix under test).

It prints one table row per variant: processes, exit statuses, how many hung (watchdog fired),
where they hung, and teardown wall times from the start file. A benchmark, not a test: the
hang rate depends on the machine and its load. Every round stops by itself (watchdog + a
deadline after which the parent kills what is left); process groups are stopped and Fast DDS
files in /dev/shm removed on exit.

    .venv/bin/python bench/teardown_storm.py [--robots 50] [--rounds 2]
        [--variants legacy,repo] [--timeout 10] [--keep DIR]
        [--native-stacks 8]   # gdb: every thread's native stack of a process still hanging
        [--lease 5]           # stress: a 5 s participant lease, hangs come more often

A round of K = 50 takes about 35 s on 2 cores (start-up and discovery about 17 s, the storm
about 4 s, or the watchdog's timeout when a process hangs).
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import dataclasses
import faulthandler
import inspect
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from xml.etree import ElementTree

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / 'tests'))

from harness import PROFILE, Processes, private_domain, ros_environment  # noqa: E402

VARIANTS = ('legacy', 'shutdown-first', 'entities-first', 'no-destroy', 'repo')
#: Seconds to wait for every process to be up and matched before a round is given up.
READY_TIMEOUT = 240.0
#: Seconds the parent waits after the watchdog's timeout before killing what is left.
KILL_MARGIN = 15.0
WORLD = 'world'
PROFILE_NS = 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'


# ---------------------------------------------------------------------------------------------
# The node processes.

def make_controller(robot: int):
    """A node shaped like the controller: the same topics, QoS and sim-time /clock."""
    from geometry_msgs.msg import TwistStamped
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Image, LaserScan
    from std_msgs.msg import Bool, String

    from mona_controller.ros import qos

    node = Node('mona_controller', namespace=qos.robot_namespace(robot),
                parameter_overrides=[Parameter('use_sim_time', value=True)])
    quiet_pub, quiet_sub = qos.QUIET_PUBLISHER, qos.QUIET_SUBSCRIPTION
    cmd = node.create_publisher(TwistStamped, qos.CMD_VEL, qos.COMMAND_QOS,
                                event_callbacks=quiet_pub)
    cleaner = node.create_publisher(Bool, qos.CLEANER, qos.CLEANER_QOS,
                                    event_callbacks=quiet_pub)
    node.seen = 0

    def on_ground(msg: Image) -> None:
        node.seen += 1
        answer = TwistStamped()
        answer.header.stamp = msg.header.stamp
        cleaner.publish(Bool(data=False))
        cmd.publish(answer)

    ground = node.create_subscription(Image, qos.GROUND, on_ground, qos.SENSOR_QOS,
                                      event_callbacks=quiet_sub)
    proximity = node.create_subscription(LaserScan, qos.PROXIMITY, lambda _: None,
                                         qos.SENSOR_QOS, event_callbacks=quiet_sub)
    node.create_subscription(String, qos.EPISODE, lambda _: None, qos.EPISODE_QOS,
                             event_callbacks=quiet_sub)

    def matched() -> bool:
        return (node.seen > 0 and cmd.get_subscription_count() > 0
                and cleaner.get_subscription_count() > 0 and ground.get_publisher_count() > 0
                and proximity.get_publisher_count() > 0)

    node.matched = matched
    return node


def make_world(robots: int):
    """The other end of every per-robot topic; readings to every robot at 5 Hz."""
    from geometry_msgs.msg import TwistStamped
    from rclpy.node import Node
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Image, LaserScan
    from std_msgs.msg import Bool, String

    from mona_controller.ros import qos

    node = Node(WORLD)
    quiet_pub, quiet_sub = qos.QUIET_PUBLISHER, qos.QUIET_SUBSCRIPTION
    clock = node.create_publisher(Clock, qos.CLOCK, qos.CLOCK_QOS)
    episode = node.create_publisher(String, qos.EPISODE, qos.EPISODE_QOS)
    episode.publish(String(data='{}'))
    grounds, scans, cmds, cleaners = [], [], [], []
    for i in range(robots):
        grounds.append(node.create_publisher(Image, qos.robot_topic(i, qos.GROUND),
                                             qos.SENSOR_QOS, event_callbacks=quiet_pub))
        scans.append(node.create_publisher(LaserScan, qos.robot_topic(i, qos.PROXIMITY),
                                           qos.SENSOR_QOS, event_callbacks=quiet_pub))
        cmds.append(node.create_subscription(TwistStamped, qos.robot_topic(i, qos.CMD_VEL),
                                             lambda _: None, qos.COMMAND_QOS,
                                             event_callbacks=quiet_sub))
        cleaners.append(node.create_subscription(Bool, qos.robot_topic(i, qos.CLEANER),
                                                 lambda _: None, qos.CLEANER_QOS,
                                                 event_callbacks=quiet_sub))
    image = Image(height=1, width=2, encoding='mono8', step=2, data=[0, 0])
    scan = LaserScan(ranges=[1.0] * 5)

    def tick() -> None:
        now = node.get_clock().now().to_msg()
        image.header.stamp = scan.header.stamp = now
        clock.publish(Clock(clock=now))
        for pub in grounds:
            pub.publish(image)
        for pub in scans:
            pub.publish(scan)

    node.create_timer(0.2, tick)

    def matched() -> bool:
        return (all(p.get_subscription_count() > 0 for p in grounds + scans)
                and all(s.get_publisher_count() > 0 for s in cmds + cleaners))

    node.matched = matched
    return node


def legacy_teardown(nodes: list, timeout: float) -> None:
    """shutdown.teardown() as it was before the fix (a hang exits with status 1)."""
    import rclpy
    faulthandler.dump_traceback_later(timeout, exit=True, file=sys.stderr)
    try:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    finally:
        faulthandler.cancel_dump_traceback_later()


def shutdown_first_teardown(nodes: list, timeout: float) -> None:
    """The context first (rcl_shutdown), then the nodes (the participant goes with the last)."""
    import rclpy
    faulthandler.dump_traceback_later(timeout, exit=True, file=sys.stderr)
    try:
        rclpy.try_shutdown()
        for node in nodes:
            node.destroy_node()
    finally:
        faulthandler.cancel_dump_traceback_later()


def entities_first_teardown(nodes: list, timeout: float, executor) -> None:
    """Every entity by hand, the executor, then each node, then the context."""
    import rclpy
    faulthandler.dump_traceback_later(timeout, exit=True, file=sys.stderr)
    try:
        executor.shutdown(timeout_sec=1.0)
        for node in nodes:
            for entity in list(node.publishers):
                node.destroy_publisher(entity)
            for entity in list(node.subscriptions):
                node.destroy_subscription(entity)
            for entity in list(node.services):
                node.destroy_service(entity)
            for entity in list(node.timers):
                node.destroy_timer(entity)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    finally:
        faulthandler.cancel_dump_traceback_later()


def worker(args: argparse.Namespace) -> int:
    """One node process: come up, report ready, wait for the start file, tear down."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    rclpy.init()
    name = WORLD if args.worker < 0 else f'controller_{args.worker}'
    node = make_world(args.robots) if args.worker < 0 else make_controller(args.worker)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    ready_file = Path(args.ready_dir) / name
    go = Path(args.go)
    next_graph_check = 0.0
    while not go.exists():
        executor.spin_once(timeout_sec=0.02)
        now = time.monotonic()
        if not ready_file.exists() and now >= next_graph_check:
            # Every participant has announced its nodes: the discovery is complete.
            next_graph_check = now + 0.5
            if node.matched() and len(node.get_node_names()) >= args.robots + 1:
                ready_file.touch()
    print(f'go seen at {time.monotonic():.3f}', flush=True)
    nodes = [node]
    if args.variant == 'legacy':
        legacy_teardown(nodes, args.timeout)
    elif args.variant == 'shutdown-first':
        shutdown_first_teardown(nodes, args.timeout)
    elif args.variant == 'entities-first':
        entities_first_teardown(nodes, args.timeout, executor)
    elif args.variant == 'no-destroy':
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
    else:
        from mona_controller.ros import shutdown
        if 'exit_status' in inspect.signature(shutdown.teardown).parameters:
            shutdown.teardown(nodes, args.timeout, exit_status=0)
        else:
            shutdown.teardown(nodes, args.timeout)
    return 0


# ---------------------------------------------------------------------------------------------
# The parent.

class NotReady(RuntimeError):
    """The processes of a round did not all come up and discover each other."""


@dataclasses.dataclass
class Exit:
    """How one process ended."""

    name: str
    status: int | None  # None: still running at the deadline, killed
    seconds: float  # from the start file to the exit (or the kill)
    hung: bool  # the watchdog fired (faulthandler's 'Timeout (...)!')
    where: str  # the innermost Python frame of the main thread when it fired


def hang_site(log: str) -> str:
    """The two innermost Python frames (function names) of the main thread when the watchdog
    fired: faulthandler lists the newest thread first, so the main thread comes last."""
    dump = log.partition('Timeout (')[2]
    blocks = re.findall(r'(?:Thread|Stack)[^\n]*\n((?:  File [^\n]*\n)+)', dump)
    if not blocks:
        return ''
    return ' < '.join(re.findall(r'line \d+ in (\S+)', blocks[-1])[:2])


def short_lease_profile(lease: float, folder: Path) -> Path:
    """The project's profile with a participant lease of ``lease`` s (announced 4 times per
    lease): remote participants' liveliness is checked that often, the timer of
    eProsima/Fast-DDS#6502, so hangs come more often (a stress setting, not the project's)."""
    ElementTree.register_namespace('', PROFILE_NS)
    tree = ElementTree.parse(PROFILE)
    builtin = tree.find(f'.//{{{PROFILE_NS}}}participant/{{{PROFILE_NS}}}rtps/'
                        f'{{{PROFILE_NS}}}builtin')
    config = ElementTree.SubElement(builtin, f'{{{PROFILE_NS}}}discovery_config')
    for tag, seconds in (('leaseDuration', lease), ('leaseAnnouncement', lease / 4)):
        duration = ElementTree.SubElement(config, f'{{{PROFILE_NS}}}{tag}')
        ElementTree.SubElement(duration, f'{{{PROFILE_NS}}}sec').text = str(int(seconds))
        ElementTree.SubElement(duration, f'{{{PROFILE_NS}}}nanosec').text = \
            str(int(round((seconds % 1) * 1e9)))
    path = folder / 'profile.xml'
    tree.write(path, xml_declaration=True, encoding='UTF-8')
    return path


def run_round(variant: str, args: argparse.Namespace, domain: int, folder: Path) -> list[Exit]:
    """Start K controllers and a world, let them match, start the storm, collect the exits."""
    folder.mkdir(parents=True)
    ready = folder / 'ready'
    ready.mkdir()
    go = folder / 'go'
    env = ros_environment(domain) | {'PYTHONFAULTHANDLER': '1',
                                     'ROS_LOG_DIR': str(folder / 'ros'),
                                     'RCUTILS_LOGGING_BUFFERED_STREAM': '0'}
    if args.lease:
        env['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(short_lease_profile(args.lease, folder))
    group = Processes(env, folder)
    common = ['--variant', variant, '--robots', str(args.robots), '--timeout',
              str(args.timeout), '--ready-dir', str(ready), '--go', str(go)]
    me = [sys.executable, str(Path(__file__).resolve())]
    try:
        group.spawn(me + ['--worker', '-1', *common], WORLD)
        for i in range(args.robots):
            group.spawn(me + ['--worker', str(i), *common], f'controller_{i}')
        started = time.monotonic()
        while len(list(ready.iterdir())) < args.robots + 1:
            dead = [p.name for p in group.started if p.poll() is not None]
            if dead:
                raise NotReady(f'{dead[0]} ended before the storm:\n{group.log(dead[0])}')
            if time.monotonic() - started > READY_TIMEOUT:
                raise NotReady(f'only {len(list(ready.iterdir()))} of {args.robots + 1} '
                                   f'processes ready after {READY_TIMEOUT:g} s')
            time.sleep(0.2)
        up = time.monotonic() - started
        time.sleep(args.settle)
        go.touch()
        t_go = time.monotonic()
        ended: dict[str, tuple[int | None, float]] = {}
        deadline = t_go + args.timeout + KILL_MARGIN
        stacks_at = t_go + args.native_stacks if args.native_stacks else float('inf')
        while len(ended) < len(group.started) and time.monotonic() < deadline:
            for process in group.started:
                if process.name not in ended and process.poll() is not None:
                    ended[process.name] = (process.returncode, time.monotonic() - t_go)
            if time.monotonic() >= stacks_at:
                stacks_at = float('inf')
                native_stacks([p for p in group.started if p.name not in ended], folder)
            time.sleep(0.01)
        for process in group.started:
            if process.name not in ended:
                ended[process.name] = (None, time.monotonic() - t_go)
    finally:
        group.stop_all()
    exits = []
    for process in group.started:
        status, seconds = ended[process.name]
        log = group.log(process.name)
        exits.append(Exit(process.name, status, seconds, 'Timeout (' in log, hang_site(log)))
    hung = sum(e.hung for e in exits)
    print(f'  {variant:15s} {len(exits)} processes up and matched in {up:5.1f} s; '
          f'{hung} hung; statuses {status_counts(exits)}; slowest exit '
          f'{max(e.seconds for e in exits):.2f} s', flush=True)
    return exits


def native_stacks(processes: list, folder: Path) -> None:
    """Every thread's native stack of each process still tearing down (gdb), to the logs."""
    for process in processes:
        out = folder / f'{process.name}.gdb.txt'
        with open(out, 'w') as file, contextlib.suppress(OSError, subprocess.SubprocessError):
            subprocess.run(['gdb', '-p', str(process.pid), '-batch', '-ex',
                            'thread apply all bt'], stdout=file, stderr=subprocess.STDOUT,
                           timeout=60)
        print(f'  native stacks of {process.name} (still in teardown): {out}', flush=True)


def status_counts(exits: list[Exit]) -> str:
    """'0 x49, 1 x2' (killed processes as 'killed')."""
    counts = collections.Counter('killed' if e.status is None else str(e.status)
                                 for e in exits)
    return ', '.join(f'{k} x{v}' for k, v in sorted(counts.items()))


def quantile(values: list[float], q: float) -> float:
    """The q-quantile of ``values`` (nearest rank)."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def report(results: dict[str, list[list[Exit]]], args: argparse.Namespace) -> None:
    """One row per variant over all its rounds."""
    print(f'\nteardown storm: K = {args.robots} controllers + 1 world, {args.rounds} round(s) per '
          f'variant, watchdog {args.timeout:g} s, {os.cpu_count()} cores')
    head = (f'{"variant":15s} {"procs":>5s} {"hung":>9s} {"rounds w/ hang":>14s} '
            f'{"exit statuses":22s} {"clean p50/p95/max s":>20s}  where it hung')
    print(head)
    print('-' * len(head))
    for variant, rounds in results.items():
        exits = [e for r in rounds for e in r]
        if not exits:
            print(f'{variant:15s} no complete round')
            continue
        hung = [e for e in exits if e.hung]
        clean = [e.seconds for e in exits if not e.hung and e.status is not None]
        times = (f'{statistics.median(clean):.2f}/{quantile(clean, 0.95):.2f}/{max(clean):.2f}'
                 if clean else '-')
        sites = collections.Counter(e.where or '?' for e in hung)
        where = '; '.join(f'{k} x{v}' for k, v in sites.most_common(3))
        print(f'{variant:15s} {len(exits):5d} {len(hung):4d} {len(hung) / len(exits):4.0%} '
              f'{sum(any(e.hung for e in r) for r in rounds):7d} of {len(rounds):<4d} '
              f'{status_counts(exits):22s} {times:>20s}  {where}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--robots', type=int, default=50, help='controller processes (K)')
    parser.add_argument('--rounds', type=int, default=2, help='rounds per variant (R)')
    parser.add_argument('--variants', default='legacy,repo',
                        help=f'comma-separated, of {", ".join(VARIANTS)}')
    parser.add_argument('--timeout', type=float, default=10.0,
                        help='the teardown watchdog in each process, s (production: 10)')
    parser.add_argument('--settle', type=float, default=2.0,
                        help='seconds between "all matched" and the start file')
    parser.add_argument('--lease', type=float, metavar='S',
                        help='stress: a participant lease of S seconds instead of the '
                             "profile's (Fast DDS default 20 s); checked more often, more "
                             'hangs')
    parser.add_argument('--native-stacks', type=float, metavar='S',
                        help='attach gdb to every process still tearing down S seconds after '
                             "the start, write its threads' native stacks (with --keep)")
    parser.add_argument('--keep', type=Path, help="keep every round's logs in this folder")
    # The node processes.
    parser.add_argument('--worker', type=int, help=argparse.SUPPRESS)
    parser.add_argument('--variant', help=argparse.SUPPRESS)
    parser.add_argument('--ready-dir', help=argparse.SUPPRESS)
    parser.add_argument('--go', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        sys.exit(worker(args))
    variants = args.variants.split(',')
    unknown = sorted(set(variants) - set(VARIANTS))
    if unknown:
        parser.error(f'unknown variant {unknown[0]!r}; known: {", ".join(VARIANTS)}')
    # SIGTERM ends the run through the finally blocks that stop every process group.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    results: dict[str, list[list[Exit]]] = {v: [] for v in variants}
    with private_domain() as domain, contextlib.ExitStack() as stack:
        root = args.keep or Path(stack.enter_context(tempfile.TemporaryDirectory()))
        print(f'domain {domain}, logs in {root}', flush=True)
        for k in range(args.rounds):
            print(f'round {k + 1} of {args.rounds}', flush=True)
            for variant in variants:
                try:
                    results[variant].append(run_round(variant, args, domain,
                                                      root / f'{variant}_{k}'))
                except NotReady as error:  # no storm without a complete discovery
                    print(f'  {variant:15s} round skipped: {error}', flush=True)
    report(results, args)


if __name__ == '__main__':
    main()

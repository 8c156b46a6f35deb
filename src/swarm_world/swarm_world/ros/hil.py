"""Hardware in the loop: N Mona firmwares in simavr, an emulated arena and tracker, and the
driver node, started together by one command (docs/driver.md, "Hardware in the loop").

``driver_hil --robots N --params-file P`` builds the firmware image of each robot (the very
image one would flash, ``make -C firmware/mona ROBOT_ID=i``), runs each in its own ``monasim``
process (firmware/sim) paced to the wall clock, and moves the robots with the world's own
physics from the wheel outputs (PWM and direction registers through the deadband map). It
feeds each firmware its IR (the world's beams at the true poses, through the calibration, as
ADC voltages) and its encoder edges, carries the link over UDP (one port per robot, with
settable latency, loss and duplication), and publishes a tracker (``geometry_msgs/PoseArray``
with settable latency and noise). It then starts ``driver_node`` on those links and that
tracker, and stops everything on SIGINT or SIGTERM (or when the driver ends). Faults are
scheduled: a reboot, a silent radio, a tracker dropout.

The robots are placed at the announced poses on each ``/episode``, as an operator would.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from swarm_world.driver.emulation import (
    TICK_US,
    EmulatedArena,
    load_sections,
    parse_battery,
    parse_window,
)
from swarm_world.driver.firmware import Firmware, FirmwareError, HilError, build_images
from swarm_world.driver.wheels import DEADBAND

USAGE_ERROR = 2


def parser() -> argparse.ArgumentParser:
    """The command line of ``driver_hil``."""
    p = argparse.ArgumentParser(
        prog='driver_hil', description=__doc__.split('\n')[0],
        epilog='Everything after -- goes to driver_node (e.g. -- -p recorders:=metrics). Exit '
               "status: the driver's when it ends by itself (0: the run was shut down); 0 "
               'when stopped by SIGINT or SIGTERM; 1 if a firmware process dies; 2 for a bad '
               'option or a missing tool.')
    add = p.add_argument
    add('--robots', type=int, required=True, metavar='N', help='emulated Monas (ids 0..N-1)')
    add('--params-file', type=Path, required=True, metavar='YAML',
        help="the project's parameter file (also the driver's)")
    add('--domain', type=int, metavar='ID', help='ROS domain id (default: ROS_DOMAIN_ID)')
    add('--out', type=Path, metavar='DIR',
        help="driver_node's output_dir (driver.json per episode) and the logs")
    add('--latency', type=float, default=0.0, metavar='S', help='link latency each way')
    add('--loss', type=float, default=0.0, metavar='P', help='link frame loss probability')
    add('--duplicate', type=float, default=0.0, metavar='P',
        help='link frame duplication probability')
    add('--tracker-rate', type=float, default=30.0, metavar='HZ', help='tracker frames/s')
    add('--tracker-latency', type=float, default=0.0, metavar='S', help='tracker latency')
    add('--tracker-noise', type=float, default=0.0, metavar='M',
        help='tracker position noise (standard deviation, m)')
    add('--tracker-topic', default=None, metavar='TOPIC',
        help='default: driver.tracker_topic of the parameter file')
    add('--deadband', type=int, default=DEADBAND, help="the firmware build's DEADBAND")
    add('--reboot', type=parse_window, action='append', default=[], metavar='ROBOT@T',
        help="reset that robot's AVR T s after the announcement (repeatable)")
    add('--silence', type=parse_window, action='append', default=[], metavar='ROBOT@T+D',
        help='its radio dead (no frame either way) from T for D s')
    add('--dropout', type=parse_window, action='append', default=[], metavar='ROBOT@T+D',
        help='the tracker does not see it from T for D s')
    add('--battery', type=parse_battery, action='append', default=[], metavar='ROBOT@T=MV',
        help='its battery reads MV from T on (a sag; default 3900 mV)')
    add('--seed', type=int, default=0, help='seed of the link loss and the tracker noise')
    return p


def split_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """(harness arguments, driver_node arguments after ``--``)."""
    argv = list(argv)
    if '--' in argv:
        at = argv.index('--')
        return argv[:at], argv[at + 1:]
    return argv, []


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``driver_hil``."""
    mine, extra = split_args(sys.argv[1:] if args is None else args)
    options = parser().parse_args(mine)
    stop = {'signal': 0}

    def on_signal(number: int, frame: object) -> None:
        stop['signal'] = number

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        return run(options, extra, stop)
    except HilError as error:
        print(f'driver_hil: {error}', file=sys.stderr)
        return USAGE_ERROR
    except FirmwareError as error:
        print(f'driver_hil: {error}', file=sys.stderr)
        return 1


def run(options: argparse.Namespace, extra: list[str], stop: dict) -> int:
    """Build, start, loop until the driver ends or a signal comes, stop everything."""
    if options.robots < 1:
        raise HilError('--robots must be at least 1')
    for name in ('loss', 'duplicate'):
        if not 0.0 <= getattr(options, name) <= 1.0:
            raise HilError(f'--{name} must be within 0..1')
    world, mona, driver = load_sections(options.params_file)
    if options.domain is not None:
        os.environ['ROS_DOMAIN_ID'] = str(options.domain)
    out = options.out or Path(os.environ.get('TMPDIR', '/tmp')) / f'driver_hil_{os.getpid()}'
    out.mkdir(parents=True, exist_ok=True)
    images, monasim = build_images(options.robots, out / 'firmware')
    firmwares = [Firmware(monasim, image, out / f'monasim_{i}.log')
                 for i, image in enumerate(images)]
    arena = EmulatedArena(options, world, mona, driver, firmwares)
    topic = options.tracker_topic or driver.tracker_topic
    links = ','.join(f'udp:127.0.0.1:{port}' for port in arena.ports())
    command = [sys.executable, '-m', 'swarm_world.ros.driver_node', '--ros-args',
               '--params-file', str(options.params_file), '-p', f'driver.links:={links}',
               '-p', f'driver.tracker_topic:={topic}', '-p', f'output_dir:={out}', *extra]
    driver_log = (out / 'driver_node.log').open('w')
    driver_process = subprocess.Popen(command, stdout=driver_log, stderr=subprocess.STDOUT,
                                      start_new_session=True)
    # Imported late: the harness above runs without ROS; the tracker needs it.
    from swarm_world.ros.hil_tracker import Tracker, capture
    tracker = Tracker(topic, arena.place)
    status = 0
    began, ticks = time.monotonic(), 0
    try:
        next_tick = time.monotonic()
        while not stop['signal']:
            if driver_process.poll() is not None:
                status = driver_process.returncode
                break
            now = time.monotonic()
            if now < next_tick:
                tracker.spin(next_tick - now)
                continue
            tracker.spin(0.0)  # also when behind: the announcements must get through
            next_tick = max(next_tick + TICK_US / 1e6, now - 0.1)  # never a burst of ticks
            arena.tick(now)
            ticks += 1
            poses = arena.tracker_poses(now)
            if poses is not None:
                arena.tracker_line.put(capture(poses), now)
            for due in arena.tracker_line.due(now):
                tracker.publish(due)
    finally:
        if driver_process.poll() is None:
            os.killpg(driver_process.pid, signal.SIGINT)
            try:
                driver_process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(driver_process.pid, signal.SIGKILL)
                driver_process.wait()
        tracker.close()
        arena.close()
        driver_log.close()
        wall = time.monotonic() - began
        print(f'driver_hil: the firmwares ran {ticks * TICK_US / 1e6:.1f} s in {wall:.1f} s '
              f'of wall time ({100 * ticks * TICK_US / 1e6 / max(wall, 1e-9):.0f} % of real '
              'time)', flush=True)
        if arena.options.silence:
            print(f'driver_hil: telemetry frames unsent while silent, per robot: '
                  f'{" ".join(map(str, arena.unsent))}', flush=True)
    return status


if __name__ == '__main__':
    sys.exit(main())

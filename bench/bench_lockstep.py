"""Benchmark: the lockstep node system against the bare messaging ceiling, in one run.

(a) scripts/swarm.sh runs one lockstep episode with N controller processes (world,
    supervisor, metrics and controllers as real processes); an observer times the episode from
    /world/status: steps per wall second and simulated seconds per wall second.
(b) bench/pingpong.py: one central process and the same N processes exchanging the same
    messages per robot and step (Image 1 x 2 and LaserScan 5 beams out, Bool and TwistStamped
    back), the central one waiting for every answer before the next round. No model, no
    world: what rclpy and DDS allow on this machine.

It prints both and the ratio (a)/(b); the target is (a) >= 80 % of (b). A benchmark, not a
test: the numbers depend on the machine and its load.

    .venv/bin/python bench/bench_lockstep.py [--population 50] [--duration 20]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pingpong  # bench/, next to this file
import rclpy
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import String

from mona_controller.ros import qos
from swarm_supervisor.system.processes import private_domain, ros_environment

REPO = Path(__file__).resolve().parents[1]


class StatusWatch:
    """Times an episode from /world/status: the first 'running' and the 'finished' report."""

    def __init__(self, context) -> None:
        self.node = rclpy.create_node('bench_watch', context=context)
        self.node.create_subscription(String, qos.STATUS, self._on_status, qos.STATUS_QOS)
        self.first: tuple[float, int] | None = None  # (wall, step) when first seen running
        self.last: tuple[float, int] | None = None
        self.final: dict | None = None

    def _on_status(self, msg: String) -> None:
        status = json.loads(msg.data)
        now = time.perf_counter()
        if status['state'] == 'running':
            self.first = self.first or (now, status['step'])
        elif status['state'] == 'finished' and self.first is not None:
            self.last = (now, status['step'])
            self.final = status


def run_system(args: argparse.Namespace, domain: int, out: Path) -> dict[str, float]:
    """(a): one lockstep episode through scripts/swarm.sh, timed by a status observer."""
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    watch = StatusWatch(context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(watch.node)
    env = ros_environment(domain) | {'SWARM_DOMAIN_ID': str(domain)}
    command = [str(REPO / 'scripts' / 'swarm.sh'), '--population', str(args.population),
               '--duration', str(args.duration), '--seed', str(args.seed), '--out', str(out),
               '--mode', 'lockstep',
               '--controllers-per-process', str(args.controllers_per_process)]
    for override in args.param:
        command += ['-p', override]
    started = time.perf_counter()
    script = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE, text=True)
    try:
        while script.poll() is None:
            executor.spin_once(timeout_sec=0.2)
        errors = script.stderr.read()
    finally:
        if script.poll() is None:
            script.terminate()
            script.wait()
        executor.shutdown()
        watch.node.destroy_node()
        rclpy.try_shutdown(context=context)
    if watch.last is None:
        raise RuntimeError(f'no finished episode seen; swarm.sh exited {script.returncode}:\n'
                           f'{errors}')
    if script.returncode != 0:
        print(f'warning: swarm.sh exited {script.returncode}:\n{errors}', file=sys.stderr)
    wall = watch.last[0] - watch.first[0]
    steps = watch.last[1] - watch.first[1]
    step_period = args.duration / watch.final['steps']
    return {'steps_per_s': steps / wall, 'sim_per_wall': steps * step_period / wall,
            'steps': steps, 'wall_s': wall, 'total_s': time.perf_counter() - started,
            'misses': sum(watch.final['misses'])}


def run_pingpong(args: argparse.Namespace, domain: int, rounds: int) -> dict[str, float]:
    """(b): the bare messaging ceiling with the same processes and messages."""
    os.environ.update(ros_environment(domain))
    processes = pingpong.spawn_responders(args.population, args.controllers_per_process)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    try:
        return pingpong.run_central(args.population, rounds, context=context)
    finally:
        rclpy.try_shutdown(context=context)
        pingpong.stop(processes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--population', type=int, default=50, help='robots (N)')
    parser.add_argument('--duration', type=float, default=20.0,
                        help='simulated seconds of the lockstep episode (a)')
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--controllers-per-process', type=int, default=1)
    parser.add_argument('-p', dest='param', action='append', default=[], metavar='NAME:=VALUE',
                        help='a parameter override for the nodes of (a), e.g. clock_period:=1.0')
    parser.add_argument('--keep', type=Path, help='keep the run of (a) in this folder')
    args = parser.parse_args()
    n = args.population
    print(f'lockstep benchmark: N = {n}, {args.controllers_per_process} controller(s) per '
          f'process, {os.cpu_count()} cores')
    with private_domain() as domain, tempfile.TemporaryDirectory() as scratch:
        out = args.keep or Path(scratch) / 'run'
        a = run_system(args, domain, out)
        print(f'(a) lockstep world:   {a["steps_per_s"]:6.1f} steps/s = '
              f'{a["sim_per_wall"]:.3f} sim s per wall s ({a["steps"]} steps in '
              f'{a["wall_s"]:.1f} s, {a["misses"]} misses; {a["total_s"]:.0f} s with start-up '
              'and teardown)', flush=True)
        b = run_pingpong(args, domain, rounds=a['steps'])
        print(f'(b) bare ping-pong:   {b["rounds_per_s"]:6.1f} rounds/s ({a["steps"]} rounds in '
              f'{b["wall_s"]:.1f} s; {1e3 / b["rounds_per_s"] / n:.2f} ms per robot per round)')
    ratio = a['steps_per_s'] / b['rounds_per_s']
    print(f'(a)/(b) = {ratio:.0%}  (target >= 80 %)')


if __name__ == '__main__':
    main()

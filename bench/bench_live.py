"""Benchmark: what watching costs the embedded runner (``mona-swarm run --live``).

Runs the same episode (N = 50 by default) alternately without the live view and with it,
while a Foxglove protocol client in another process subscribes to the topics the shipped
layout shows (``--all-topics``: every channel) and receives every message (without decoding
it: the viewer, Foxglove, is another program), and prints
each runner's sim seconds per wall second and the live view's cost in percent of the
embedded runner's speed, three ways: from the wall clock, from the runner process's CPU time
(the live server's threads included), and as the share of the run spent in the live view's
own code in the runner's thread. The bound we hold it to: at most 10 %. A benchmark, not a test:
on a shared 2-core machine other processes (the client's among them) make the wall-clock
figures noisy; the share of the live view's own code is the steadiest of the three.

    .venv/bin/python bench/bench_live.py [--population 50] [--duration 300] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

from mona_controller.topics import POSES
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_episode
from swarm_supervisor.media.live import LiveServer, LiveView


class TimedView(LiveView):
    """The live view, timing the work it does when it sends (frames, metric samples) in the
    runner's thread: the steadiest measure on a loaded machine. Its per-step bookkeeping (a
    counter, a flag) is not timed: timing 10,000 calls a second would cost more than it."""

    spent = 0.0

    def _frame(self, episode, wall, force=False) -> None:
        started = time.perf_counter()
        super()._frame(episode, wall, force)
        self.spent += time.perf_counter() - started

    def _metrics(self, episode) -> None:
        started = time.perf_counter()
        super()._metrics(episode)
        self.spent += time.perf_counter() - started


CLIENT = """
import sys
sys.path.insert(0, {tests!r})
from foxclient import capture
seen = capture({url!r}, topics={topics!r}, seconds=3600, decode=False)
print(sum(len(m) for m in seen.messages.values()), flush=True)
"""


def layout_topics() -> list[str]:
    """The topics the shipped layout (ros_ws/config/foxglove_layout.json) shows."""
    layout = json.loads((Path(__file__).resolve().parents[1] / 'ros_ws' / 'config' /
                         'foxglove_layout.json').read_text())
    topics = set()
    for settings in layout['configById'].values():
        topics |= set(settings.get('topics', {}))
        topics |= {settings['topicPath']} if 'topicPath' in settings else set()
        topics |= {settings.get('imageMode', {}).get('imageTopic')} - {None}
        topics |= {path['value'].split('.')[0] for path in settings.get('paths', [])}
    return sorted(topics)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--population', type=int, default=50)
    parser.add_argument('--duration', type=float, default=300.0)
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--all-topics', action='store_true',
                        help='the client subscribes to every channel (default: the topics the '
                             'shipped Foxglove layout shows, what a viewer subscribes to)')
    args = parser.parse_args()
    topics = None if args.all_topics else layout_topics()
    config = load_config().replace(episode={'population': args.population,
                                            'duration': args.duration, 'seed': 1})
    run_episode(config.replace(episode={'duration': 5.0}))  # compile the kernels first
    tests = str(Path(__file__).resolve().parents[1] / 'tests')
    plain, live, plain_cpu, live_cpu, own = [], [], [], [], []
    for _ in range(args.repeats):
        cpu = time.process_time()
        plain.append(run_episode(config).real_time_factor)
        plain_cpu.append(time.process_time() - cpu)
        server = LiveServer(0)
        client = subprocess.Popen([sys.executable, '-c', CLIENT.format(
            tests=tests, url=server.url, topics=topics)],
                                  stdout=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 30
            while not server.wanted(POSES):  # the client has subscribed
                if time.monotonic() > deadline:
                    raise SystemExit('the benchmark client never subscribed')
                time.sleep(0.05)
            view = TimedView(server)
            cpu = time.process_time()
            result = run_episode(config, observers=[view])
            own.append(view.spent / result.wall_time)
            live_cpu.append(time.process_time() - cpu)  # the server's threads included
            live.append(result.real_time_factor)
        finally:
            server.stop()
            received, _ = client.communicate(timeout=60)
        print(f'without live view {plain[-1]:6.1f}x real time, {plain_cpu[-1]:5.2f} s CPU; '
              f'with it {live[-1]:6.1f}x, {live_cpu[-1]:5.2f} s CPU, {100 * own[-1]:.1f} % of '
              f"the run in the live view's code ({view.frames} frames, the client received "
              f'{received.strip()} messages)', flush=True)
    base, watched = statistics.median(plain), statistics.median(live)
    cpu_base, cpu_watched = statistics.median(plain_cpu), statistics.median(live_cpu)
    watching = 'every channel' if args.all_topics else "the layout's topics"
    print(f'N = {args.population}, {args.duration:g} s, medians of {args.repeats}, the client '
          f'subscribed to {watching}: '
          f'{base:.1f}x without, {watched:.1f}x with the live view and a subscribed client '
          f'(wall clock: {100 * (1 - watched / base):.1f} % slower); CPU time of the runner '
          f'process {cpu_base:.2f} s without, {cpu_watched:.2f} s with: it costs '
          f"{100 * (1 - cpu_base / cpu_watched):.1f} % of the embedded runner's speed "
          f"(bound: 10 %); the live view's own code took {100 * statistics.median(own):.1f} % "
          'of the run')


if __name__ == '__main__':
    main()

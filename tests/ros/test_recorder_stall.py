"""A stalled recorder, in this process: the metrics node in an executor of its own that stops
being spun at a chosen moment while the world, the controllers and the supervisor go on. Its
DDS threads keep receiving meanwhile, so keep-last-1 topics (the cue map, the sources) keep
only their latest message, as in a stopped process. Whatever the moment, the world waits for
what the record still lacks and the bag is complete, by the verdict ``analyze`` gives."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from mona_controller.contract import WorldState
from mona_controller.ros.controller_node import ControllerNode
from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.completeness import check_bag_file
from swarm_metrics.bags.reader import read_episode_bag
from swarm_metrics.ros.metrics_node import MetricsNode
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.runner import run_episode
from swarm_supervisor.system.ros.supervisor_node import Supervisor
from swarm_world.ros.world_node import WorldNode

pytestmark = pytest.mark.ros

POPULATION, DURATION, SEED = 3, 3.0, 7
MOMENTS = ('announcement', 'recording', 'middle', 'late', 'end', 'next')


class Run:
    """World, controllers and supervisor in ``executor``; the metrics node in its own."""

    def __init__(self, executor, tmp_path, lag: float) -> None:
        overrides = [Parameter('episode.population', value=POPULATION),
                     Parameter('episode.duration', value=DURATION),
                     Parameter('episode.seed', value=SEED),
                     Parameter('output_dir', value=str(tmp_path))]
        recorders = Parameter('recorders', value='metrics')
        context = executor.context
        self.executor = executor
        self.world = WorldNode(context=context, parameter_overrides=[
            *overrides, recorders, Parameter('recorder_lag', value=lag)])
        self.controllers = [ControllerNode(i, context=context) for i in range(POPULATION)]
        self.supervisor = Supervisor(context=context,
                                     parameter_overrides=[*overrides, recorders])
        for node in (self.world, *self.controllers, self.supervisor):
            executor.add_node(node)
        self.metrics = MetricsNode(context=context, parameter_overrides=[overrides[-1]])
        self.recorder = SingleThreadedExecutor(context=context)
        self.recorder.add_node(self.metrics)
        self.stalled = False
        self.closing = False
        #: Set by the recorder's thread once it has seen ``stalled`` (no spin under way).
        self.idle = threading.Event()
        self.thread = threading.Thread(target=self._spin_recorder, daemon=True)
        self.thread.start()
        self.max_lead_ns = 0  # how far the world got ahead of the record (sim ns)
        self.held = False  # the world held a step after step 0 for its recorder

    def _spin_recorder(self) -> None:
        while not self.closing:
            if self.stalled:
                self.idle.set()
                time.sleep(0.01)
            else:
                self.recorder.spin_once(timeout_sec=0.05)

    def spin(self, condition: Callable[[], bool], what: str, timeout: float = 60.0) -> None:
        """Spin the system until ``condition()`` (the recorder spins in its own thread)."""
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, (
                f'timed out after {timeout} s: {what} (the world {self.world.state.name} at '
                f'step {self.world.world.steps}, held since {self.world.held_since}; the '
                f"supervisor's status {self.supervisor.status})")
            self.executor.spin_once(timeout_sec=0.05)
            episode = self.metrics.recorder.episode
            if episode is not None and self.world.state is WorldState.RUNNING:
                self.max_lead_ns = max(self.max_lead_ns,
                                       self.world.time_ns - episode.recorded_ns)
            # (Every episode holds step 0 for a moment: until the start is recorded.)
            self.held |= self.world.held_since is not None and self.world.world.steps > 0

    def pause(self) -> None:
        """Stop spinning the recorder; return once no spin of it is under way."""
        self.idle.clear()
        self.stalled = True
        self.idle.wait()  # the spin under way has ended (on a busy machine, whenever that is)

    def stall(self, until: Callable[[], bool] = lambda: True, at_least: float = 1.0) -> None:
        """Spin everything but the recorder (paused now, unless it is already) until
        ``until()`` holds, ``at_least`` seconds; then let the recorder spin again."""
        if not self.stalled:
            self.pause()
        shortest = time.monotonic() + at_least
        self.spin(lambda: time.monotonic() > shortest and until(), 'the end of the stall')
        self.stalled = False

    def holding(self) -> bool:
        """The world holds a step for its recorder (and has for a second)."""
        since = self.world.held_since
        return since is not None and (self.world.wall.now() - since).nanoseconds > 1e9

    def sim_s(self) -> float:
        return (self.world.time_ns - self.world.start_ns) / 1e9

    def closed(self, episode: int) -> bool:
        report = self.supervisor.recorders.closed(episode, self.world.start_ns).get('metrics')
        return report is not None

    def close(self) -> None:
        self.closing = True
        self.thread.join()
        self.recorder.remove_node(self.metrics)
        self.metrics.destroy_node()
        self.recorder.shutdown()


@pytest.fixture
def system(executor, tmp_path):
    runs: list[Run] = []

    def make(lag: float = 10.0) -> Run:
        runs.append(Run(executor, tmp_path, lag))
        return runs[-1]

    yield make
    for run in runs:
        run.close()


@pytest.mark.parametrize('moment', MOMENTS)
def test_a_recorder_stalled_at_any_moment_ends_with_a_complete_bag(system, tmp_path, moment):
    # In the middle the world must hold for its recorder: a 1 s lag (the sample period).
    run = system(lag=1.0 if moment == 'middle' else 10.0)
    supervisor, world = run.supervisor, run.world
    episodes = 2 if moment == 'next' else 1
    run.spin(lambda: supervisor.status is not None, 'the world')
    if moment == 'announcement':  # before the first announcement: the world waits for it
        run.pause()
        supervisor.reset_episode(SEED, episode=0)
        run.stall(lambda: world.state is WorldState.WAITING, at_least=2.0)
    else:
        supervisor.reset_episode(SEED, episode=0)
    if moment == 'recording':  # it opened the bag and said so: the world publishes the start
        run.spin(lambda: run.metrics._confirmed, 'the recording report')
        run.stall(lambda: run.holding() or run.sim_s() > 1.5)
        assert world.world.steps == 0  # held until the start is recorded
    elif moment in ('middle', 'late'):
        at = DURATION / 3 if moment == 'middle' else DURATION - 0.6
        run.spin(lambda: run.sim_s() >= at, f'sim time {at} s')
        run.stall(lambda: run.holding() or world.state is WorldState.FINISHED)
        assert (world.state is WorldState.FINISHED) == (moment == 'late')
    elif moment == 'end':  # across the end: stalled as the world finishes
        run.spin(lambda: world.state is WorldState.FINISHED, 'the end')
        run.stall(at_least=2.0)
    for k in range(episodes):
        run.spin(lambda k=k: run.closed(k), f'episode {k} recorded')
        if k + 1 < episodes:  # around the next announcement
            run.pause()
            supervisor.reset_episode(SEED + k + 1, episode=k + 1)
            run.stall(lambda: world.state is WorldState.WAITING, at_least=2.0)

    # The world held for its recorder instead of running away from the record.
    assert run.held == (moment == 'middle')
    assert run.max_lead_ns <= (1.0 if moment == 'middle' else 10.0) * 1e9 + world.params.step_ns
    assert supervisor.recorders.latest['metrics'].complete
    for k in range(episodes):
        bag = tmp_path / f'episode_{k}' / 'bag'
        assert check_bag_file(bag) == [], k  # analyze's verdict: complete
        recorded = read_episode_bag(bag)
        start = recorded.announcement['start_ns']
        assert recorded.sources[0][0] == recorded.cue_maps[0][0] == start
        config = SwarmConfig().replace(episode={'population': POPULATION,
                                                'duration': DURATION, 'seed': SEED + k})
        assert recompute(recorded).rows == run_episode(config).metrics  # every sample

"""The supervisor node: places the robots and runs the episodes of a ros run.

For episode k it derives ``seed_k = episode.seed + k``, places the robots from that seed
(:func:`swarm_supervisor.engine.episode.place_swarm`, as the embedded runner does), announces the
episode on ``/episode`` and waits until the world reports it finished and every expected recorder
(``recorders``) reports its record of it closed and complete. After the last episode it
announces the shutdown, which ends the world and every controller node.

Usable from Python like nav2's simple commander::

    supervisor = Supervisor()
    supervisor.wait_for_world()
    for k, seed in enumerate((1, 2, 3)):
        supervisor.reset_episode(seed, episode=k)
        status = supervisor.run_episode()
    supervisor.shutdown_run()
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import rclpy
from rclpy.duration import Duration
from rclpy.node import Node
from std_msgs.msg import String

from mona_controller.contract import (
    Announcement,
    ContractError,
    RecorderBook,
    RecorderReport,
    WorldState,
    WorldStatus,
    recorder_names,
)
from mona_controller.controllers import states_of
from mona_controller.node_help import node_parser, parse_node_args
from mona_controller.ros import qos
from mona_controller.ros.ros_params import declare_plugins, declare_section
from mona_controller.ros.shutdown import STOPPED, raise_unless_stopped, teardown
from mona_controller.schema import ParameterError, param, validate
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import place_swarm
from swarm_supervisor.system.progress import ProgressFile
from swarm_supervisor.system.records import RUN_FILE
from swarm_world.placement import PlacementError

#: Wall seconds without a world node before a running episode counts as failed.
WORLD_GONE = 5.0


class SupervisorError(RuntimeError):
    """The run cannot go on: no world, a rejected or failed episode, a timeout."""


@dataclasses.dataclass(frozen=True)
class SupervisorParams:
    """Options of the supervisor node (the episode itself is the ``episode`` section)."""

    episodes: int = param(1, unit='episodes', low=1, high=1_000_000,
                          doc='episodes to run; episode k uses seed episode.seed + k')
    output_dir: str = param('', doc="directory for run.json ('' = none)")
    world_timeout: float = param(120.0, unit='s (wall)', low=0.1, high=86400.0,
                                 doc='how long to wait for the world node to appear')
    episode_timeout: float = param(3600.0, unit='s (wall)', low=0.1, high=1e7,
                                   doc='how long one episode may take before the run fails')
    recorders: str = param('', doc="comma-separated node names of the recorders (the metrics "
                                   "node: 'metrics') whose complete record of each episode "
                                   "the run needs ('' = none)")
    record_timeout: float = param(60.0, unit='s (wall)', low=0.1, high=86400.0,
                                  doc='how long to wait, after the world finished an episode, '
                                      'for every recorder to close its record')

    def __post_init__(self) -> None:
        validate(self)


class Supervisor(Node):
    """Announces episodes to the world and the controllers and follows the world's status."""

    def __init__(self, **kwargs) -> None:
        super().__init__('supervisor', **kwargs)
        loaded = declare_plugins(self)  # before the parameters that may name what they add
        self.config = dataclasses.replace(declare_section(self, SwarmConfig), plugins=loaded)
        self.options = declare_section(self, SupervisorParams)
        if self.config.episode.population < 1:
            raise ParameterError(f'episode.population = {self.config.episode.population} is out '
                                 'of range for a ros run: allowed [1, 100000] robots (a world '
                                 'without robots has nothing to step in lockstep)')
        self.status: WorldStatus | None = None  #: the world's latest
        self.announcement: Announcement | None = None  #: the latest episode announced
        self.records: list[dict] = []
        self.recorders = RecorderBook(recorder_names(self.options.recorders))
        #: <output_dir>/progress.json, for the launcher's progress line
        self.progress = ProgressFile(Path(self.options.output_dir), self.options.episodes,
                                     self.config.episode.duration) \
            if self.options.output_dir else None
        self.episode_pub = self.create_publisher(String, qos.EPISODE, qos.EPISODE_QOS)
        self.create_subscription(String, qos.STATUS, self._on_status, qos.STATUS_QOS)
        self.create_subscription(String, qos.RECORDERS, self._on_recorder, qos.RECORDERS_QOS)

    def _on_status(self, msg: String) -> None:
        try:
            self.status = WorldStatus.from_json(msg.data)
        except ContractError as error:
            self.get_logger().warning(str(error), throttle_duration_sec=5.0)
            return
        if self.progress is not None:
            try:
                self.progress.note(self.status)
            except OSError as error:  # only the progress line suffers
                self.get_logger().warning(f'progress.json: {error}', throttle_duration_sec=60.0)

    def _on_recorder(self, msg: String) -> None:
        try:
            self.recorders.update(RecorderReport.from_json(msg.data))
        except ContractError as error:
            self.get_logger().warning(str(error), throttle_duration_sec=5.0)

    def _spin_until(self, condition, timeout: float, what: str, *,
                    watch_world: bool = False) -> None:
        """Spin this node until ``condition()`` holds; raise after ``timeout`` wall seconds,
        or (``watch_world``) once the world node has been gone for ``WORLD_GONE`` seconds."""
        now = time.monotonic()
        deadline, seen = now + timeout, now
        while not condition():
            now = time.monotonic()
            if now > deadline:
                raise SupervisorError(f'timed out after {timeout:g} s waiting for {what}')
            if watch_world:
                if self.count_publishers(qos.STATUS) > 0:
                    seen = now
                elif now - seen > WORLD_GONE:
                    raise SupervisorError(f'the world node is gone (no publisher on '
                                          f'{qos.STATUS} for {WORLD_GONE:g} s) while waiting '
                                          f'for {what}')
            executor = self.executor  # rclpy.spin_once leaves a stale one behind: check
            if executor is not None and self in executor.get_nodes():
                executor.spin_once(timeout_sec=0.1)  # e.g. with in-process world, controllers
            else:
                rclpy.spin_once(self, timeout_sec=0.1)

    def wait_for_world(self, timeout: float | None = None) -> WorldStatus:
        """Wait for the world node's status; return it."""
        self._spin_until(lambda: self.status is not None,
                         timeout or self.options.world_timeout,
                         f'the world node (no {qos.STATUS})')
        return self.status

    def reset_episode(self, seed: int, episode: int | None = None) -> Announcement:
        """Place the robots from ``seed`` and announce the episode; return the announcement.

        Sim time carries on from the world's current time (``start_ns``), so it never runs
        backwards across episodes.
        """
        if self.status is None:
            self.wait_for_world()
        if episode is None:
            episode = self.announcement.episode + 1 if self.announcement else 0
        config = self.config.replace(episode={'seed': seed})
        try:
            poses = place_swarm(config, seed)
        except PlacementError as error:
            raise ParameterError(str(error)) from None
        self.announcement = Announcement(
            episode, seed=seed, population=config.episode.population,
            duration=config.episode.duration, start_ns=self.status.time_ns,
            poses=tuple(map(tuple, poses.tolist())), parameters=config.to_dict(),
            plugins=tuple(config.plugin_records()), states=states_of(config.controller.kind))
        self.episode_pub.publish(String(data=self.announcement.to_json()))
        self.get_logger().info(f'episode {episode}: seed {seed}, {len(poses)} robots, start '
                               f'{self.announcement.start_ns} ns')
        return self.announcement

    def run_episode(self, timeout: float | None = None) -> WorldStatus:
        """Wait until the world finishes the announced episode; return its final status.

        Raises:
            SupervisorError: the world rejected or failed the episode, or it took too long.
        """
        announced = self.announcement
        episode = announced.episode

        def over() -> bool:
            return self.status.episode == episode and self.status.ended

        self._spin_until(over, timeout or self.options.episode_timeout,
                         f'episode {episode} to finish', watch_world=True)
        final = self.status
        if final.state is WorldState.FAILED:
            raise SupervisorError(f'the world failed episode {episode}: {final.error}')
        records = self._wait_for_records(episode)
        self.records.append({'episode': episode, 'seed': announced.seed,
                             'population': announced.population,
                             'duration': announced.duration, 'start_ns': announced.start_ns,
                             'end_ns': final.time_ns, 'steps': final.step,
                             'misses': sum(final.misses), 'dropped': final.dropped,
                             'records': records})
        self.get_logger().info(f'episode {episode} finished: {final.step} steps, misses '
                               f'{sum(final.misses)}, dropped {final.dropped}')
        return final

    def _wait_for_records(self, episode: int) -> dict[str, dict]:
        """Wait until every expected recorder closed its record of ``episode``; return
        {recorder: {path, complete, problems}}.

        Raises:
            SupervisorError: a recorder did not close it in ``record_timeout``, or its record
                is incomplete (the message says what it lacks).
        """
        start_ns = self.announcement.start_ns

        def closed() -> bool:
            return len(self.recorders.closed(episode, start_ns)) == len(self.recorders.names)

        try:
            self._spin_until(closed, self.options.record_timeout,
                             f'the recorders to close episode {episode}')
        except SupervisorError:
            missing = sorted(set(self.recorders.names)
                             - set(self.recorders.closed(episode, start_ns)))
            raise SupervisorError(f'episode {episode}: the recorder(s) {", ".join(missing)} '
                                  f'did not close their record within '
                                  f"{self.options.record_timeout:g} s of the episode's end "
                                  f'on {qos.RECORDERS}') from None
        reports = self.recorders.closed(episode, start_ns)
        incomplete = [f'{name} ({report.path}): {"; ".join(report.problems)}'
                      for name, report in reports.items() if not report.complete]
        if incomplete:
            raise SupervisorError(f'episode {episode}: incomplete record from '
                                  + ', '.join(incomplete))
        return {name: {'path': report.path, 'complete': report.complete,
                       'problems': list(report.problems)} for name, report in reports.items()}

    def shutdown_run(self) -> None:
        """Announce the end of the run; every node exits."""
        episode = self.announcement.episode if self.announcement else -1
        self.episode_pub.publish(String(data=Announcement(episode, shutdown=True).to_json()))
        self.episode_pub.wait_for_all_acked(Duration(seconds=5))

    def write_run(self) -> None:
        """<output_dir>/run.json: the seeds and parameters of the episodes run so far."""
        if not self.options.output_dir:
            return
        folder = Path(self.options.output_dir)
        folder.mkdir(parents=True, exist_ok=True)
        document = {'runner': 'ros', 'seed': self.config.episode.seed,
                    'episodes': self.records, 'parameters': self.config.to_dict(),
                    'plugins': self.config.plugin_records()}
        partial = folder / (RUN_FILE + '.partial')
        partial.write_text(json.dumps(document, indent=1) + '\n')
        os.replace(partial, folder / RUN_FILE)

    def run(self) -> None:
        """Run ``episodes`` episodes from ``episode.seed`` on, then shut the run down."""
        self.wait_for_world()
        try:
            for k in range(self.options.episodes):
                self.reset_episode(self.config.episode.seed + k, episode=k)
                self.run_episode()
                self.write_run()
        finally:
            if self.context.ok():  # not after Ctrl-C
                self.shutdown_run()


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``supervisor_node [--ros-args ...]``: 0 once every episode finished."""
    argv = list(sys.argv if args is None else args)
    parse_node_args(node_parser('supervisor_node', __doc__.split('\n')[0],
                                sections={'': SupervisorParams},
                                statuses={0: 'every episode finished and its record complete',
                                          130: 'stopped by SIGINT / SIGTERM'}), argv[1:])
    rclpy.init(args=argv)
    node = None
    status = 1  # an exception that escapes is a failure, also if teardown then hangs
    logger = rclpy.logging.get_logger('supervisor')
    try:
        node = Supervisor()
        node.run()
        status = 0
    except STOPPED as error:
        raise_unless_stopped(error)
        status = 130
    except ParameterError as error:
        logger.fatal(f'bad parameter: {error}')
        status = 2
    except SupervisorError as error:
        logger.fatal(str(error))
        status = 1
    finally:
        teardown([node], exit_status=status)  # run.json is written: durable
    return status


if __name__ == '__main__':
    sys.exit(main())

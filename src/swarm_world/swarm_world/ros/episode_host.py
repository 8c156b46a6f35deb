"""A world-side node's episodes: the part of the world node (and the driver node) that is not
stepping (docs/interfaces.md).

:class:`EpisodeHost` declares the parameters, builds the world and its topics
(:class:`~swarm_world.ros.world_topics.WorldTopics`, one
:class:`~swarm_world.ros.robot_link.RobotLink` per robot), and runs each announced episode's
life: it checks the announcement (:func:`swarm_world.hosting.unplayable`), resets the
world, waits for every robot's controller and every recorder, publishes the start, and at the
end the final map, status and state (``output_dir``), or the failure. How the world steps in
between is its subclass's: :class:`~swarm_world.ros.world_node.WorldNode` (lockstep or
realtime rounds with the controllers), which :meth:`EpisodeHost.start_stepping` hands over to.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from geometry_msgs.msg import TwistStamped
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.task import Future
from std_msgs.msg import Bool, String, UInt8

from mona_controller import contract
from mona_controller.mona import MonaParams
from mona_controller.ros import qos
from mona_controller.ros.ros_params import declare_plugins, declare_section
from swarm_world.hosting import unconfirmed, unconnected, unplayable, write_final
from swarm_world.lockstep import Lockstep
from swarm_world.params import WorldNodeParams, WorldParams
from swarm_world.ros.robot_link import RobotLink
from swarm_world.ros.world_topics import WorldTopics
from swarm_world.sensing.params import SensingParams
from swarm_world.timing import steps_for
from swarm_world.world import World


class EpisodeHost(Node):
    """The episodes of a world-side node; its subclass steps them (:meth:`start_stepping`,
    :meth:`on_cmd`)."""

    def __init__(self, *, parameter_overrides: Sequence[Parameter] = (), **kwargs) -> None:
        super().__init__('world', parameter_overrides=[Parameter('use_sim_time', value=False),
                                                       *parameter_overrides], **kwargs)
        declare_plugins(self)  # before world.layout, which may name a plug-in's layout
        self.params = declare_section(self, WorldParams, 'world.')
        self.mona = declare_section(self, MonaParams, 'mona.')
        self.sensing = declare_section(self, SensingParams, 'sensing.')
        self.options = declare_section(self, WorldNodeParams)
        self.world = World(self.params, self.mona, self.sensing)
        self.world.warm_up()  # the compiled kernels now, not in an episode's first step
        self.wall = Clock(clock_type=ClockType.STEADY_TIME)
        self.finished = Future()  #: done on the shutdown announcement, or a fatal error
        self.exit_status = 0

        self.topics = WorldTopics(self, self.world.arena)  # the obstacles go out at once
        self.create_subscription(String, qos.EPISODE, self.on_episode, qos.EPISODE_QOS)
        self.recorders = contract.RecorderBook(contract.recorder_names(self.options.recorders))
        self.create_subscription(String, qos.RECORDERS, self.on_recorder, qos.RECORDERS_QOS)
        self.clock_ns = round(self.options.clock_period * 1e9)  # publishing periods
        self.map_ns = round(self.options.map_period * 1e9)
        self.status_ns = round(self.options.status_period * 1e9)

        self.links: list[RobotLink] = []
        self.episode = -1
        self.announcement: contract.Announcement | None = None
        self.state = contract.WorldState.WAITING
        self.error = ''
        self.start_ns = 0  # absolute sim time of the episode's step 0
        self.time_ns = 0  # absolute sim time now (monotonic across episodes)
        self.total_steps = 0
        self.lockstep = Lockstep(0, 0, self.options.absent_after, self.params.step_ns)
        self.cleaning_events = 0  # /world/cleaning messages of this episode
        self.poses_ns = -1  # the time of the episode's latest /world/poses (-1: none yet)
        #: Each robot's controller state after its latest answer (0 before its first: every
        #: controller kind starts an episode there, docs/interfaces.md).
        self.states = np.zeros(0, dtype=np.uint8)
        #: The colours of the controller kind's states (the announced ones), by code.
        self.palette: tuple[tuple[float, ...], ...] = ()
        self.connect_timer = None
        self.step_timer = None  # lockstep: the deadline; realtime: the step period
        self.resend_timer = None  # lockstep, step 0 only
        self.hold_timer = None  # a recorder lacks the start or (lockstep) fell behind
        self.held_since = None
        self.pace_timer = None  # lockstep with real_time_factor: the next round's start
        self.pace_origin: tuple[int, int] | None = None  # (wall ns, sim ns) of step 0
        self._last_heartbeat = self.wall.now()
        self.deadline_period = 0.0
        self.publish_status()
        self.get_logger().info(f'world ready ({self.options.mode}), waiting for an episode')

    # --- episodes -----------------------------------------------------------------------

    def on_episode(self, msg: String) -> None:
        """Start the announced episode, or finish on the shutdown announcement."""
        try:
            announcement = contract.Announcement.from_json(msg.data)
        except contract.ContractError as error:
            self.get_logger().error(f'ignoring /episode: {error}')
            return
        if announcement.shutdown:
            self.get_logger().info('shutdown announced')
            self._stop_timers()
            if not self.finished.done():
                self.finished.set_result(True)
            return
        if self.announcement is not None and self.announcement.key == announcement.key:
            return  # redelivered
        problem = self._check_announcement(announcement)
        self._stop_timers()
        self.announcement = announcement
        self.episode = announcement.episode
        if problem:
            self.fail(f'episode {self.episode} rejected: {problem}', fatal=False)
            return
        population = announcement.population
        self.world.reset(np.array(announcement.poses), announcement.seed)
        self.start_ns = self.time_ns = announcement.start_ns
        self.total_steps = steps_for(announcement.duration, self.params.step_ns)
        # A round is a control step: realtime counts a command stale in control steps.
        self.lockstep = Lockstep(population, self.start_ns, self.options.absent_after,
                                 self.params.step_ns * self.params.control_steps)
        self.cleaning_events = 0
        self.poses_ns = -1
        self.states = np.zeros(population, dtype=np.uint8)
        self.palette = tuple(state.colour for state in announcement.robot_states())
        while len(self.links) < population:
            self.links.append(RobotLink(self, len(self.links), self.mona, self.on_state,
                                        self.on_cleaner, self.on_cmd))
        self.state = contract.WorldState.WAITING
        self.error = ''
        self.publish_status()
        self.get_logger().info(f'episode {self.episode}: {population} robots, seed '
                               f'{announcement.seed}, {self.total_steps} steps from '
                               f'{self.start_ns} ns; waiting for the controllers')
        self.connect_started = self.wall.now()
        self.connect_timer = self.create_timer(0.05, self._wait_for_controllers,
                                               clock=self.wall)

    @property
    def sections(self) -> dict[str, Any]:
        """The world's parameter sections by name, as an announcement carries them."""
        return {'world': self.params, 'mona': self.mona, 'sensing': self.sensing}

    def _check_announcement(self, announcement: contract.Announcement) -> str:
        """What this world cannot play of a well-formed announcement ('' = nothing)."""
        return unplayable(announcement, self.time_ns, self.sections)

    def on_recorder(self, msg: String) -> None:
        """A recorder's report: it records the episode, how far, or that it closed it."""
        try:
            self.recorders.update(contract.RecorderReport.from_json(msg.data))
        except contract.ContractError as error:
            self.get_logger().warning(str(error), throttle_duration_sec=5.0)

    def _not_recording(self) -> list[str]:
        """Expected recorders that have not confirmed the episode, or whose subscriptions to
        the poses, states and cleaning events (volatile: no history for late joiners) are not
        matched."""
        missing = self.recorders.not_recording(self.episode, self.start_ns)
        subscribed = self.topics.recording_subscriptions()
        if not missing and subscribed < len(self.recorders.names):
            return [f'{len(self.recorders.names) - subscribed} subscription(s) to {qos.POSES}, '
                    f'{qos.ROBOT_STATES} and {qos.CLEANING}']
        return missing

    def _wait_for_controllers(self) -> None:
        n = self.world.population
        missing = [i for i in range(n) if not self.links[i].connected()]
        not_recording = self._not_recording()
        if not missing and not not_recording:
            self.destroy_timer(self.connect_timer)
            self.connect_timer = None
            self._begin()
            return
        waited = (self.wall.now() - self.connect_started).nanoseconds / 1e9
        if waited > self.options.start_timeout:
            self.destroy_timer(self.connect_timer)
            self.connect_timer = None
            timeout = self.options.start_timeout
            self.fail(unconnected(self.episode, timeout, missing, n) if missing else
                      unconfirmed(self.episode, timeout, not_recording))

    def _begin(self) -> None:
        """Publish the episode's start (t = 0's cue map, sources, states and poses), then
        step once every recorder has recorded it (:meth:`_held_by_recorders`)."""
        self.state = contract.WorldState.RUNNING
        self.publish_clock()
        self.publish_map()
        self.publish_status()
        self._publish_poses()
        self.get_logger().info(f'episode {self.episode} running')
        self.start_stepping()

    def _finish(self) -> None:
        self._stop_timers()
        self.state = contract.WorldState.FINISHED
        self.publish_map()
        self.publish_status()
        self._write_final()
        self.get_logger().info(f'episode {self.episode} finished at {self.time_ns} ns; '
                               f'misses {int(self.lockstep.misses.sum())}, dropped '
                               f'{self.lockstep.dropped}')

    def fail(self, error: str, fatal: bool = True) -> None:
        """Report an error on /world/status; a fatal one ends the node with status 1."""
        self.get_logger().error(error)
        self._stop_timers()
        self.state = contract.WorldState.FAILED
        self.error = error
        self.publish_status()
        if fatal and not self.finished.done():
            self.exit_status = 1
            self.finished.set_result(False)

    def _stop_timers(self) -> None:
        for timer in (self.connect_timer, self.step_timer, self.resend_timer,
                      self.hold_timer, self.pace_timer):
            if timer is not None:
                self.destroy_timer(timer)
        self.connect_timer = self.step_timer = self.resend_timer = self.hold_timer = None
        self.pace_timer = None
        self.held_since = None

    # --- commands -----------------------------------------------------------------------

    def on_state(self, robot_id: int, msg: UInt8) -> None:
        """A controller's state after its latest answer (for /world/robot_states)."""
        if robot_id < len(self.states):
            self.states[robot_id] = msg.data

    def on_cleaner(self, robot_id: int, msg: Bool) -> None:
        """A controller says whether its robot is cleaning."""
        self.lockstep.set_cleaner(robot_id, msg.data)

    def start_stepping(self) -> None:
        """Step the episode whose start is published (the subclass's)."""
        raise NotImplementedError

    def on_cmd(self, robot_id: int, msg: TwistStamped) -> None:
        """A wheel command (the subclass's: its rounds take it)."""
        raise NotImplementedError

    def close(self) -> None:
        """Release what the node holds beyond its ROS entities, before its teardown (nothing
        here; the driver node's links)."""

    # --- world topics -------------------------------------------------------------------

    def publish_clock(self) -> None:
        """Publish /clock at the world's sim time."""
        self.topics.clock(self.time_ns)

    def publish_map(self) -> None:
        """Publish the cue map, its occupancy grid, the sources and the robot markers."""
        self.topics.map(self.world, self.params.cell_size, self.states, self.mona.body_radius,
                        self.palette, self.time_ns)
        if self.state is contract.WorldState.FINISHED:  # the last poses: no readings round's
            self._publish_poses()

    def _publish_poses(self) -> None:
        """The poses, just after the controllers' states: the n-th /world/robot_states goes with
        the n-th /world/poses of the episode (the states array carries no stamp)."""
        self.topics.poses(self.world.poses, self.states, self.time_ns)
        self.poses_ns = self.time_ns

    def publish_status(self) -> None:
        """Publish /world/status with the lockstep counters."""
        counters = self.lockstep.counters()
        status = contract.WorldStatus(
            self.episode, self.state, step=self.world.steps, steps=self.total_steps,
            time_ns=self.time_ns, mode=self.options.mode, misses=tuple(counters['misses']),
            absent=tuple(counters['absent']), dropped=counters['dropped'],
            duplicates=counters['duplicates'], cleaning_events=self.cleaning_events,
            error=self.error)
        self.topics.status(status)

    def _write_final(self) -> None:
        """<output_dir>/episode_<k>/world_final.npz: the final state, for parity checks."""
        if self.options.output_dir:
            write_final(Path(self.options.output_dir) / f'episode_{self.episode}', self.world,
                        self.lockstep, seed=self.announcement.seed, episode=self.episode,
                        time_ns=self.time_ns, start_ns=self.start_ns, sections=self.sections)

"""The world node: the simulated arena behind the per-robot topics of docs/interfaces.md.

Messages in, two pure cores, messages out: :class:`~swarm_world.world.World` is the arena,
:class:`~swarm_world.lockstep.Lockstep` the rounds with the controllers (which command counts,
misses, absent robots). On each ``/episode`` announcement the node resets the world, waits for
every robot's controller and every recorder, then steps in lockstep or realtime. It publishes
/clock, the ground-truth poses with the controllers' states, the cleaning events, the cue map
and grid, the sources, robot markers and /world/status, once (latched) its obstacles, and
with ``output_dir`` writes each episode's final state.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import PoseArray, TwistStamped
from nav_msgs.msg import OccupancyGrid
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.task import Future
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import Image, LaserScan
from std_msgs.msg import Bool, String, UInt8, UInt8MultiArray
from visualization_msgs.msg import MarkerArray

from mona_controller.contract import (
    Announcement,
    ContractError,
    RecorderBook,
    RecorderReport,
    WorldState,
    WorldStatus,
    recorder_names,
)
from mona_controller.mona import MonaParams
from mona_controller.node_help import node_parser, parse_node_args
from mona_controller.ros import qos
from mona_controller.ros.messages import (
    fill_readings,
    ground_image,
    proximity_scan,
    set_stamp,
    stamp_to_ns,
)
from mona_controller.ros.ros_params import declare_plugins, declare_section
from mona_controller.ros.shutdown import deliver, teardown
from mona_controller.schema import ParameterError, differences, to_mapping
from swarm_world.lockstep import Lockstep
from swarm_world.params import WorldNodeParams, WorldParams
from swarm_world.ros.world_messages import (
    PoseArrayFiller,
    cue_grid,
    cue_image,
    obstacle_markers,
    robot_markers,
    robot_states,
    source_markers,
)
from swarm_world.sensing.params import SensingParams
from swarm_world.timing import crossed, steps_for
from swarm_world.world import World

FINAL_FILE = 'world_final.npz'
#: Wall seconds between repeats of step 0's readings to robots that have not answered yet.
RESEND_PERIOD = 0.2
#: Wall seconds between looks at a recorder that holds the world back.
HOLD_POLL = 0.02


class RobotLink:
    """The world's end of one robot's topics, with messages built once and reused."""

    def __init__(self, node: Node, robot_id: int, mona: MonaParams, on_state, on_cleaner,
                 on_cmd):
        self.robot_id = robot_id
        self.ground_msg = ground_image(robot_id)
        self.scan_msg = proximity_scan(robot_id, mona)
        quiet_pub, quiet_sub = qos.QUIET_PUBLISHER, qos.QUIET_SUBSCRIPTION
        self.ground_pub = node.create_publisher(Image, qos.robot_topic(robot_id, qos.GROUND),
                                                qos.SENSOR_QOS, event_callbacks=quiet_pub)
        self.scan_pub = node.create_publisher(LaserScan,
                                              qos.robot_topic(robot_id, qos.PROXIMITY),
                                              qos.SENSOR_QOS, event_callbacks=quiet_pub)
        # state and cleaner before cmd_vel: when all are ready the executor takes them in this
        # order (the controller publishes them in it).
        self.state_sub = node.create_subscription(
            UInt8, qos.robot_topic(robot_id, qos.STATE), partial(on_state, robot_id),
            qos.STATE_QOS, event_callbacks=quiet_sub)
        self.cleaner_sub = node.create_subscription(
            Bool, qos.robot_topic(robot_id, qos.CLEANER), partial(on_cleaner, robot_id),
            qos.CLEANER_QOS, event_callbacks=quiet_sub)
        self.cmd_sub = node.create_subscription(
            TwistStamped, qos.robot_topic(robot_id, qos.CMD_VEL), partial(on_cmd, robot_id),
            qos.COMMAND_QOS, event_callbacks=quiet_sub)

    def connected(self) -> bool:
        """A controller listens to both readings and publishes commands."""
        return (self.ground_pub.get_subscription_count() > 0
                and self.scan_pub.get_subscription_count() > 0
                and self.cmd_sub.get_publisher_count() > 0)

    def publish(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
                stamp_ns: int) -> None:
        """Publish one robot's readings for the step stamped ``stamp_ns``."""
        fill_readings(self.ground_msg, self.scan_msg, ground, ranges, is_robot, stamp_ns)
        self.resend()

    def resend(self) -> None:
        """Publish the current readings (again)."""
        self.ground_pub.publish(self.ground_msg)
        self.scan_pub.publish(self.scan_msg)

    def take_waiting(self) -> None:
        """Handle the cleaner and command messages that wait in the subscriptions now, as the
        executor would (state and cleaner first)."""
        for subscription in (self.state_sub, self.cleaner_sub, self.cmd_sub):
            while True:
                with subscription.handle:
                    taken = subscription.handle.take_message(subscription.msg_type,
                                                             subscription.raw)
                if taken is None:
                    break
                subscription.callback(taken[0])


class WorldNode(Node):
    """The simulated world of a Mona swarm, stepped in lockstep with its controllers."""

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

        self.clock_pub = self.create_publisher(ClockMsg, qos.CLOCK, qos.CLOCK_QOS)
        self.poses_pub = self.create_publisher(PoseArray, qos.POSES, qos.POSES_QOS)
        self.cleaning_pub = self.create_publisher(PoseArray, qos.CLEANING, qos.CLEANING_QOS)
        self.map_pub = self.create_publisher(Image, qos.CUE_MAP, qos.MAP_QOS)
        self.grid_pub = self.create_publisher(OccupancyGrid, qos.CUE_GRID, qos.MAP_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, qos.MARKERS, qos.MARKERS_QOS)
        self.states_pub = self.create_publisher(UInt8MultiArray, qos.ROBOT_STATES,
                                                qos.ROBOT_STATES_QOS)
        self.sources_pub = self.create_publisher(MarkerArray, qos.SOURCES, qos.SOURCES_QOS)
        # Static scenery, latched: the arena is the node's for its lifetime (an announcement
        # with other world parameters is rejected), so once is enough for every episode.
        self.obstacles_pub = self.create_publisher(MarkerArray, qos.OBSTACLES,
                                                   qos.OBSTACLES_QOS)
        self.obstacles_pub.publish(obstacle_markers(self.world.arena))
        self.status_pub = self.create_publisher(String, qos.STATUS, qos.STATUS_QOS)
        self.create_subscription(String, qos.EPISODE, self.on_episode, qos.EPISODE_QOS)
        self.recorders = RecorderBook(recorder_names(self.options.recorders))
        self.create_subscription(String, qos.RECORDERS, self.on_recorder, qos.RECORDERS_QOS)
        self.poses_filler = PoseArrayFiller()
        self.cleaning_filler = PoseArrayFiller()
        self.clock_msg = ClockMsg()
        self.clock_ns = round(self.options.clock_period * 1e9)  # publishing periods
        self.map_ns = round(self.options.map_period * 1e9)
        self.status_ns = round(self.options.status_period * 1e9)

        self.links: list[RobotLink] = []
        self.episode = -1
        self.announcement: Announcement | None = None
        self.state = WorldState.WAITING
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
        self._last_heartbeat = self.wall.now()
        self.deadline_period = 0.0
        self.publish_status()
        self.get_logger().info(f'world ready ({self.options.mode}), waiting for an episode')

    # --- episodes -----------------------------------------------------------------------

    def on_episode(self, msg: String) -> None:
        """Start the announced episode, or finish on the shutdown announcement."""
        try:
            announcement = Announcement.from_json(msg.data)
        except ContractError as error:
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
        self.state = WorldState.WAITING
        self.error = ''
        self.publish_status()
        self.get_logger().info(f'episode {self.episode}: {population} robots, seed '
                               f'{announcement.seed}, {self.total_steps} steps from '
                               f'{self.start_ns} ns; waiting for the controllers')
        self.connect_started = self.wall.now()
        self.connect_timer = self.create_timer(0.05, self._wait_for_controllers,
                                               clock=self.wall)

    def _check_announcement(self, announcement: Announcement) -> str:
        """What this world cannot play of a well-formed announcement ('' = nothing)."""
        if announcement.population < 1:
            return 'no robots'
        if announcement.start_ns < self.time_ns:
            return (f'start_ns {announcement.start_ns} is before the world time '
                    f'{self.time_ns}: sim time must not run backwards')
        try:
            announcement.robot_states()  # what the robots' markers are coloured by
        except KeyError as error:
            return f'no controller states announced, and {error.args[0]}'
        for section, mine in (('world', self.params), ('mona', self.mona),
                              ('sensing', self.sensing)):
            theirs = announcement.parameters.get(section)
            # As parameters (defaults applied), naming the keys that differ.
            differ = [] if theirs is None else differences(mine, theirs, f'{section}.')
            if differ:
                return (f'the announced {section} parameters differ from the world '
                        "node's: " + '; '.join(differ)
                        + ': start every node with the same --params-file')
        return ''

    def on_recorder(self, msg: String) -> None:
        """A recorder's report: it records the episode, how far, or that it closed it."""
        try:
            self.recorders.update(RecorderReport.from_json(msg.data))
        except ContractError as error:
            self.get_logger().warning(str(error), throttle_duration_sec=5.0)

    def _not_recording(self) -> list[str]:
        """Expected recorders that have not confirmed the episode, or whose subscriptions to
        the poses, states and cleaning events (volatile: no history for late joiners) are not
        matched."""
        missing = self.recorders.not_recording(self.episode, self.start_ns)
        subscribed = min(self.poses_pub.get_subscription_count(),
                         self.cleaning_pub.get_subscription_count(),
                         self.states_pub.get_subscription_count())
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
            shown = ', '.join(str(i) for i in missing[:20]) + (', ...' if len(missing) > 20
                                                                else '')
            if missing:
                self.fail(f'episode {self.episode}: after {self.options.start_timeout:g} s no '
                          f'controller connected for {len(missing)} of {n} robots ({shown}); '
                          f'start a mona_controller_node for each of /mona_0 .. '
                          f'/mona_{n - 1}')
                return
            self.fail(f'episode {self.episode}: after {self.options.start_timeout:g} s the '
                      f'recorder(s) {", ".join(not_recording)} did not confirm that they '
                      f'record the episode on {qos.RECORDERS}; is the metrics_node running '
                      f'and alive?')

    def _begin(self) -> None:
        """Publish the episode's start (t = 0's cue map, sources, states and poses), then
        step once every recorder has recorded it (:meth:`_held_by_recorders`)."""
        self.state = WorldState.RUNNING
        self.publish_clock()
        self.publish_map()
        self.publish_status()
        self._publish_poses()
        self.get_logger().info(f'episode {self.episode} running')
        if self.options.mode == 'lockstep':
            self._start_round()
        else:
            self._start_realtime()

    def _start_realtime(self) -> None:
        """Realtime: once the recorders hold the start, publish the readings of step 0 and
        step on the wall clock."""
        if self._held_by_recorders(self._start_realtime):
            return
        self._publish_readings()
        self.step_timer = self.create_timer(self.params.step_period, self.on_realtime_tick,
                                            clock=self.wall)

    def _finish(self) -> None:
        self._stop_timers()
        self.state = WorldState.FINISHED
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
        self.state = WorldState.FAILED
        self.error = error
        self.publish_status()
        if fatal and not self.finished.done():
            self.exit_status = 1
            self.finished.set_result(False)

    def _stop_timers(self) -> None:
        for timer in (self.connect_timer, self.step_timer, self.resend_timer,
                      self.hold_timer):
            if timer is not None:
                self.destroy_timer(timer)
        self.connect_timer = self.step_timer = self.resend_timer = self.hold_timer = None
        self.held_since = None

    # --- commands -----------------------------------------------------------------------

    def on_state(self, robot_id: int, msg: UInt8) -> None:
        """A controller's state after its latest answer (for /world/robot_states)."""
        if robot_id < len(self.states):
            self.states[robot_id] = msg.data

    def on_cleaner(self, robot_id: int, msg: Bool) -> None:
        """A controller says whether its robot is cleaning."""
        self.lockstep.set_cleaner(robot_id, msg.data)

    def on_cmd(self, robot_id: int, msg: TwistStamped) -> None:
        """A wheel command: handed to the lockstep round of its stamp."""
        if self.state is not WorldState.RUNNING:
            return
        stamp = stamp_to_ns(msg.header.stamp)
        linear, angular = msg.twist.linear.x, msg.twist.angular.z
        if self.options.mode == 'realtime':
            self.lockstep.keep_latest(robot_id, stamp, linear, angular)
            return
        answer = self.lockstep.answer(robot_id, stamp, linear, angular)
        if answer.rejoined:
            self.get_logger().info(f'robot {robot_id} is back at step {self.world.steps}')
        if answer.complete:
            self._advance()

    def on_deadline(self) -> None:
        """The lockstep deadline passed: the robots that did not answer hold still."""
        # The executor runs ready timers before ready subscriptions: on a stalled machine the
        # deadline can fire with the commands already waiting. Take those first, so a round
        # is missed only when its commands really did not come.
        stamp = self.lockstep.expected_ns
        for i in self.lockstep.waiting():
            self.links[i].take_waiting()
            if not self.lockstep.open or self.lockstep.expected_ns != stamp:
                return  # the round completed on a command just taken
        late, gone = self.lockstep.deadline()
        if len(late):
            self.get_logger().warning(
                f'step {self.world.steps}: no command from robots {late.tolist()} within '
                f'{self.deadline_period:g} s; they hold still',
                throttle_duration_sec=5.0)
        if len(gone):
            self.get_logger().warning(
                f'robots {gone.tolist()} missed {self.options.absent_after} steps in a row: '
                'absent, no longer waited for until they answer again')
        self._advance()

    # --- stepping -----------------------------------------------------------------------

    def _start_round(self) -> None:
        """Lockstep: publish this step's poses, hold while a recorder needs it, then publish
        the readings and wait for every present robot."""
        if self.world.steps >= self.total_steps:
            self._finish()
            return
        if self.poses_ns != self.time_ns:  # first, so a recorder held for can take its sample
            self._publish_poses()
        if self._held_by_recorders(self._start_round):
            return
        self.lockstep.start_round(self.time_ns)
        # Step 0 may wait as long as connecting may take (new DDS matches can hold the first
        # messages back); later rounds wait lockstep_deadline.
        first = self.world.steps == 0
        self._arm_deadline(self.options.start_timeout if first else
                           self.options.lockstep_deadline)
        self._publish_readings()
        if first:
            # New DDS matches may drop or delay the first messages either way: repeat step 0's
            # readings to the robots that have not answered (they repeat their answer).
            self.resend_timer = self.create_timer(RESEND_PERIOD, self._resend, clock=self.wall)

    def _held_by_recorders(self, resume: Callable[[], None]) -> bool:
        """Hold the next step (``resume`` it later) while a recorder has not recorded the
        episode's start, which went out on keep-last-1 topics that the next map would
        overwrite, or, in lockstep, is more than ``recorder_lag`` behind (its subscriptions
        keep a bounded history); fail the episode after ``recorder_timeout``."""
        if not self.recorders.names:
            return False
        lag_ns = round(self.options.recorder_lag * 1e9)
        needed = self.start_ns if lag_ns == 0 else max(self.start_ns, self.time_ns - lag_ns)
        behind = self.recorders.behind(self.episode, self.start_ns, needed)
        if not behind:
            if self.hold_timer is not None:
                self.destroy_timer(self.hold_timer)
                self.hold_timer, self.held_since = None, None
            return False
        now = self.wall.now()
        if self.held_since is None:
            self.held_since = now
            if self.step_timer is not None:
                self.step_timer.cancel()  # no deadline while no round is under way
            # The recorder samples only up to a status (it counts the cleaning events): say
            # where the world stands, or a recorder one sample behind would wait for ever.
            self.publish_status()
            what = ('record the start' if needed == self.start_ns else 'catch up')
            self.get_logger().info(f'step {self.world.steps}: waiting for recorder(s) '
                                   f'{", ".join(behind)} to {what}',
                                   throttle_duration_sec=5.0)
            self.hold_timer = self.create_timer(HOLD_POLL, resume, clock=self.wall)
        elif (now - self.held_since).nanoseconds / 1e9 > self.options.recorder_timeout:
            how = ("did not record the episode's start (t = 0's poses, states, cue map and "
                   'sources)' if needed == self.start_ns else
                   f'fell more than {self.options.recorder_lag:g} s of sim time behind and '
                   'did not catch up')
            self.fail(f'episode {self.episode}: the recorder(s) {", ".join(behind)} {how} '
                      f'within {self.options.recorder_timeout:g} s; is the metrics_node '
                      'alive?', fatal=False)
        else:
            self._heartbeat()
        return True

    def _arm_deadline(self, period: float) -> None:
        if self.step_timer is not None and self.deadline_period == period:
            self.step_timer.reset()
            return
        if self.step_timer is not None:
            self.destroy_timer(self.step_timer)
        self.step_timer = self.create_timer(period, self.on_deadline, clock=self.wall)
        self.deadline_period = period

    def _resend(self) -> None:
        for i in self.lockstep.waiting():
            self.links[i].resend()
        self._heartbeat()

    def _heartbeat(self) -> None:
        """While the world waits (step 0 may take up to start_timeout, a hold up to
        recorder_timeout), its status says once a second of wall time that it is alive: a
        recorder takes a silent world for a dead one."""
        now = self.wall.now()
        if (now - self._last_heartbeat).nanoseconds >= 1e9:
            self._last_heartbeat = now
            self.publish_status()

    def _advance(self) -> None:
        """Apply the round's commands for a control period (``control_steps`` steps, the
        wheels holding them), publishing as the world steps, then start the next round."""
        if self.resend_timer is not None:
            self.destroy_timer(self.resend_timer)
            self.resend_timer = None
            self.get_logger().info(f'episode {self.episode}: step 0 done, stepping')
        self._step()
        while self.world.steps % self.params.control_steps and \
                self.world.steps < self.total_steps:
            self._publish_poses()  # every step's, as the recorders sample them
            self._step()
        self._start_round()

    def on_realtime_tick(self) -> None:
        """Realtime: step with each robot's latest command; stale ones hold still. Readings go
        out at every control step; the poses at every step."""
        if self.world.steps % self.params.control_steps == 0:
            self.lockstep.realtime_step(self.time_ns)
        self._step()
        if self.world.steps >= self.total_steps:
            self._finish()
            return
        if self.world.steps % self.params.control_steps == 0:
            self._publish_readings()
        else:
            self._publish_poses()

    def _step(self) -> None:
        before = self.time_ns
        self.world.step(*self.lockstep.commands())
        self.time_ns = self.start_ns + self.world.time_ns
        if len(self.world.cleaned):
            self.cleaning_pub.publish(self.cleaning_filler.fill(
                self.world.poses[self.world.cleaned], self.time_ns))
            self.cleaning_events += 1
        if crossed(before, self.time_ns, self.clock_ns):
            self.publish_clock()
        relative_before, relative = before - self.start_ns, self.world.time_ns
        if crossed(relative_before, relative, self.map_ns):
            self.publish_map()
        if crossed(relative_before, relative, self.status_ns):
            self.publish_status()

    def _publish_poses(self) -> None:
        """The poses, just after the controllers' states: the n-th /world/robot_states goes with
        the n-th /world/poses of the episode (the states array carries no stamp)."""
        self.states_pub.publish(robot_states(self.states))
        self.poses_pub.publish(self.poses_filler.fill(self.world.poses, self.time_ns))
        self.poses_ns = self.time_ns

    def _publish_readings(self) -> None:
        readings = self.world.sense()
        if self.poses_ns != self.time_ns:  # not yet (the start's went out with it, _begin)
            self._publish_poses()
        for link, ground, ranges, is_robot in zip(self.links, readings.ground, readings.ranges,
                                                  readings.is_robot):
            link.publish(ground, ranges, is_robot, self.time_ns)

    # --- world topics -------------------------------------------------------------------

    def publish_clock(self) -> None:
        """Publish /clock at the world's sim time."""
        set_stamp(self.clock_msg.clock, self.time_ns)
        self.clock_pub.publish(self.clock_msg)

    def publish_map(self) -> None:
        """Publish the cue map, its occupancy grid, the sources and the robot markers."""
        self.map_pub.publish(cue_image(self.world.cue, self.time_ns))
        field = self.world.field
        self.sources_pub.publish(source_markers(
            field.names, field.source_positions(self.world.time_ns / 1e9), self.time_ns))
        self.grid_pub.publish(cue_grid(self.world.cue, self.params.cell_size, self.time_ns))
        self.markers_pub.publish(robot_markers(self.world.poses, self.states,
                                               self.mona.body_radius, self.time_ns,
                                               palette=self.palette))
        if self.state is WorldState.FINISHED:  # the last poses, which no readings round carries
            self._publish_poses()

    def publish_status(self) -> None:
        """Publish /world/status with the lockstep counters."""
        counters = self.lockstep.counters()
        status = WorldStatus(
            self.episode, self.state, step=self.world.steps, steps=self.total_steps,
            time_ns=self.time_ns, mode=self.options.mode, misses=tuple(counters['misses']),
            absent=tuple(counters['absent']), dropped=counters['dropped'],
            duplicates=counters['duplicates'], cleaning_events=self.cleaning_events,
            error=self.error)
        self.status_pub.publish(String(data=status.to_json()))

    def _write_final(self) -> None:
        """<output_dir>/episode_<k>/world_final.npz: the final state, for parity checks."""
        if not self.options.output_dir:
            return
        folder = Path(self.options.output_dir) / f'episode_{self.episode}'
        folder.mkdir(parents=True, exist_ok=True)
        partial_path = folder / (FINAL_FILE + '.partial.npz')
        np.savez(partial_path, poses=self.world.poses.astype(np.float64),
                 cue=self.world.cue.astype(np.float32), misses=self.lockstep.misses,
                 dropped=np.int64(self.lockstep.dropped),
                 duplicates=np.int64(self.lockstep.duplicates),
                 seed=np.int64(self.announcement.seed), episode=np.int64(self.episode),
                 steps=np.int64(self.world.steps), time_ns=np.int64(self.time_ns),
                 start_ns=np.int64(self.start_ns),
                 parameters=json.dumps({'world': to_mapping(self.params),
                                        'mona': to_mapping(self.mona),
                                        'sensing': to_mapping(self.sensing)}))
        os.replace(partial_path, folder / FINAL_FILE)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``world_node [--ros-args ...]``; exits when the run is over."""
    argv = list(sys.argv if args is None else args)
    parse_node_args(node_parser('world_node', __doc__.split('\n')[0], sections={
        '': WorldNodeParams, 'world.': WorldParams, 'mona.': MonaParams,
        'sensing.': SensingParams}), argv[1:])
    rclpy.init(args=argv)
    node = None
    status = 1  # an exception that escapes is a failure, also if teardown then hangs
    try:
        node = WorldNode()
        rclpy.spin_until_future_complete(node, node.finished)
        status = node.exit_status
        deliver([node])  # the final status and state reach every reader, also one that lost them
    except (KeyboardInterrupt, ExternalShutdownException):
        status = 0
    except ParameterError as error:
        rclpy.logging.get_logger('world').fatal(f'bad parameter: {error}')
        status = 2
    finally:
        teardown([node], exit_status=status)  # world_final.npz is written when it finishes
    return status


if __name__ == '__main__':
    sys.exit(main())

"""The world node: the simulated arena behind the per-robot topics of docs/interfaces.md.

Messages in, two pure cores, messages out: :class:`~swarm_world.world.World` is the arena,
:class:`~swarm_world.lockstep.Lockstep` the rounds with the controllers (which command counts,
misses, absent robots). On each ``/episode`` announcement the node resets the world, waits for
every robot's controller and every recorder, then steps in lockstep or realtime. It publishes
/clock, the ground-truth poses with the controllers' states, the cleaning events, the cue map
and grid, the sources, robot markers and /world/status, once (latched) its obstacles, and
with ``output_dir`` writes each episode's final state.

The episodes' life (parameters, announcements, the controllers and recorders joining, start,
end, status, topics) is :class:`~swarm_world.ros.episode_host.EpisodeHost`'s; this module
steps them: the lockstep rounds (readings out, every present robot's command or the deadline,
a control period of steps), the realtime ticks, and the hold while a recorder lags.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

import rclpy
from geometry_msgs.msg import TwistStamped

from mona_controller.contract import WorldState
from mona_controller.mona import MonaParams
from mona_controller.node_help import node_parser, parse_node_args
from mona_controller.ros.messages import stamp_to_ns
from mona_controller.ros.shutdown import STOPPED, deliver, raise_unless_stopped, teardown
from mona_controller.ros.spinning import spin_until
from mona_controller.schema import ParameterError
from swarm_world.hosting import hold_failure, hold_until_ns
from swarm_world.params import WorldNodeParams, WorldParams
from swarm_world.ros.episode_host import EpisodeHost
from swarm_world.sensing.params import SensingParams
from swarm_world.timing import crossed

#: Wall seconds between repeats of step 0's readings to robots that have not answered yet.
RESEND_PERIOD = 0.2
#: Wall seconds between looks at a recorder that holds the world back.
HOLD_POLL = 0.02


class WorldNode(EpisodeHost):
    """The simulated world of a Mona swarm, stepped in lockstep with its controllers."""

    def start_stepping(self) -> None:
        """Lockstep: the first round; realtime: the wall clock's ticks."""
        if self.options.mode == 'lockstep':
            self._start_round()
        else:
            self._start_realtime()

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
        # On a stalled machine the deadline's timer can come before the commands that arrived
        # in time are handled. Take those first, so a round is missed only when its commands
        # really did not come.
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
        if self._held_by_recorders(self._start_round) or self._paced(self._start_round):
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
        needed = hold_until_ns(self.start_ns, self.time_ns, self.options.recorder_lag)
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
            waiting = f'step {self.world.steps}: waiting for recorder(s) {", ".join(behind)}'
            # Two call sites, two throttles: step 0's line must not hide a first catch-up.
            if needed == self.start_ns:
                self.get_logger().info(f'{waiting} to record the start',
                                       throttle_duration_sec=5.0)
            else:
                self.get_logger().info(f'{waiting} to catch up', throttle_duration_sec=5.0)
            self.hold_timer = self.create_timer(HOLD_POLL, resume, clock=self.wall)
        elif (now - self.held_since).nanoseconds / 1e9 > self.options.recorder_timeout:
            self.fail(hold_failure(self.episode, behind, needed == self.start_ns,
                                   self.options.recorder_lag, self.options.recorder_timeout),
                      fatal=False)
        else:
            self._heartbeat()
        return True

    def _paced(self, resume: Callable[[], None]) -> bool:
        """With ``real_time_factor`` > 0: hold the next round (``resume`` it later) until the
        wall clock since step 0 catches up with the sim time at that factor."""
        if self.pace_timer is not None:
            self.destroy_timer(self.pace_timer)
            self.pace_timer = None
        factor = self.options.real_time_factor
        if factor <= 0:  # unpaced: no clock read on the hot path
            return False
        now = self.wall.now().nanoseconds
        if self.world.steps == 0 or self.pace_origin is None:
            self.pace_origin = (now, self.time_ns)
            return False
        due = self.pace_origin[0] + (self.time_ns - self.pace_origin[1]) / factor
        if now >= due:
            return False
        if self.step_timer is not None:
            self.step_timer.cancel()  # no deadline while no round is under way
        self.pace_timer = self.create_timer((due - now) / 1e9, resume, clock=self.wall)
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

    def _start_realtime(self) -> None:
        """Realtime: once the recorders hold the start, publish the readings of step 0 and
        step on the wall clock."""
        if self._held_by_recorders(self._start_realtime):
            return
        self._publish_readings()
        self.step_timer = self.create_timer(self.params.step_period, self.on_realtime_tick,
                                            clock=self.wall)

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
            self.topics.cleaning(self.world.poses[self.world.cleaned], self.time_ns)
            self.cleaning_events += 1
        if crossed(before, self.time_ns, self.clock_ns):
            self.publish_clock()
        relative_before, relative = before - self.start_ns, self.world.time_ns
        if crossed(relative_before, relative, self.map_ns):
            self.publish_map()
        if crossed(relative_before, relative, self.status_ns):
            self.publish_status()

    def _publish_readings(self) -> None:
        readings = self.world.sense()
        if self.poses_ns != self.time_ns:  # not yet (the start's went out with it, _begin)
            self._publish_poses()
        for link, ground, ranges, is_robot in zip(self.links, readings.ground, readings.ranges,
                                                  readings.is_robot):
            link.publish(ground, ranges, is_robot, self.time_ns)


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``world_node [--ros-args ...]``; exits when the run is over."""
    argv = list(sys.argv if args is None else args)
    parse_node_args(node_parser('world_node', __doc__.split('\n')[0], sections={
        '': WorldNodeParams, 'world.': WorldParams, 'mona.': MonaParams,
        'sensing.': SensingParams}), argv[1:])
    rclpy.init(args=argv)
    return run(WorldNode, 'world')


def run(make: Callable[[], EpisodeHost], name: str) -> int:
    """Spin the node ``make`` builds (rclpy initialised) until its run is over, then tear it
    down; its exit status: the node's, 0 on Ctrl-C or an external shutdown, 2 for a bad
    parameter (logged by the logger ``name``), 1 for an exception that escapes."""
    node = None
    status = 1  # an exception that escapes is a failure, also if teardown then hangs
    try:
        node = make()
        spin_until([node], node.finished.done)
        status = node.exit_status
        deliver([node])  # the final status and state reach every reader, also one that lost them
    except STOPPED as error:
        raise_unless_stopped(error)
        status = 0
    except ParameterError as error:
        rclpy.logging.get_logger(name).fatal(f'bad parameter: {error}')
        status = 2
    finally:
        if node is not None:
            node.close()
        teardown([node], exit_status=status)  # world_final.npz is written when it finishes
    return status


if __name__ == '__main__':
    sys.exit(main())

"""The driver node: real Monas behind the world node's contract (docs/driver.md).

It is the world node in realtime mode with the simulation taken out: the poses come from an
overhead tracker (``driver.tracker_topic``), the IR from each robot's telemetry over its link
(serial or UDP, docs/link.md), and the commands go out over the link as wheel commands. The
cue, the ground readings at the tracked poses, the cleaning and every topic of
docs/interfaces.md are the world node's own code (:class:`~.tracked.TrackedWorld`). Sim time
follows the host's monotonic clock: a late tick catches up the steps it missed. Faults (a
silent robot, a tracker dropout) hold the robot still and list it absent; each is counted in
``/driver/status`` and ``episode_<k>/driver.json`` (docs/reliability.md, "Driver faults").
"""

from __future__ import annotations

import json
import os
import secrets
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import PoseArray
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from mona_controller.contract import Announcement, ContractError, WorldState
from mona_controller.link.frame import Decoder
from mona_controller.link.transport import SerialTransport, Transport, UdpTransport
from mona_controller.mona import MonaParams
from mona_controller.node_help import node_parser, parse_node_args
from mona_controller.ros import qos
from mona_controller.ros.ros_params import declare_section
from mona_controller.schema import ParameterError
from swarm_world.driver.fleet import Fleet
from swarm_world.driver.params import UDP_PREFIX, DriverParams, udp_address
from swarm_world.driver.tracked import TrackedWorld
from swarm_world.driver.wheels import to_permille, twist_to_wheels
from swarm_world.frames import yaw_from_quaternion
from swarm_world.params import WorldNodeParams, WorldParams
from swarm_world.ros.world_node import WorldNode, run
from swarm_world.sensing.params import SensingParams

DRIVER_STATUS = '/driver/status'
DRIVER_FILE = 'driver.json'
#: The most steps one late tick catches up (a longer stall loses sim time, and says so).
MAX_CATCH_UP = 10
#: Wall seconds between the stops sent to every robot while no episode runs.
KEEP_ALIVE = 0.1
#: The tracker's QoS: the latest poses matter, a lost one is replaced by the next.
TRACKER_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                         reliability=ReliabilityPolicy.BEST_EFFORT)


def open_link(url: str, baud: int) -> Transport:
    """The transport a link URL names: ``udp:HOST:PORT`` or a serial port / pyserial URL."""
    if url.startswith(UDP_PREFIX):
        return UdpTransport(('0.0.0.0', 0), udp_address(url))
    return SerialTransport(url, baud)


class DriverNode(WorldNode):
    """The world node's topics for real (or emulated) Monas: tracker poses, link telemetry."""

    def __init__(self, *, parameter_overrides: Sequence[Parameter] = (), **kwargs) -> None:
        # Real robots run on the wall clock: always realtime.
        super().__init__(parameter_overrides=[*parameter_overrides,
                                              Parameter('mode', value='realtime')], **kwargs)
        self.driver = declare_section(self, DriverParams, 'driver.')
        urls = self.driver.link_urls()
        if not urls:
            raise ParameterError('driver.links is empty: give one link per robot, e.g. '
                                 '-p driver.links:=udp:10.0.0.3:9000,/dev/ttyUSB1')
        if self.mona.ir_count != 5:
            raise ParameterError(f'mona.ir_count = {self.mona.ir_count}: a Mona reports 5 IR '
                                 'sensors (docs/link.md, "Telemetry")')
        self.world = TrackedWorld(self.params, self.mona, self.sensing,
                                  self.driver.calibration(), self.driver.robot_margin)
        # Load the compiled sensor kernels now, not in the first tick of an episode.
        self.world.reset(np.array([[0.5, 0.5, 0.0], [0.7, 0.5, 0.0]]))
        self.world.sense()
        self.world.reset(np.zeros((0, 3)))
        self.transports: dict[str, Transport] = {}
        for url in urls:  # robots that share a port (a radio) share its transport
            if url not in self.transports:
                try:
                    self.transports[url] = open_link(url, self.driver.baud)
                except (OSError, ValueError) as error:  # serial.SerialException is an OSError
                    self.close_ports()
                    raise ParameterError(f'driver.links: cannot open {url!r}: {error}') \
                        from None
        self.link_of = [self.transports[url] for url in urls]
        self.decoders = {url: Decoder() for url in self.transports}
        self.fleet = Fleet(len(urls), secrets.randbits(16), self.driver.silent_after,
                           self.driver.tracker_timeout, self.driver.battery_low)
        self.host_start = time.monotonic()
        self.step_origin: float | None = None  # host time of the episode's step 0
        self.next_keep_alive = 0.0
        self.stalls = 0  # ticks that could not catch up every due step
        self.driver_pub = self.create_publisher(String, DRIVER_STATUS, qos.STATUS_QOS)
        self.create_subscription(PoseArray, self.driver.tracker_topic, self.on_tracker,
                                 TRACKER_QOS)
        self.create_timer(self.driver.poll_period, self.poll_links, clock=self.wall)
        self.tracker_frames = 0  # tracker messages in a frame other than world: ignored
        self.get_logger().info(f'driver: {len(urls)} robot link(s) on '
                               f'{len(self.transports)} port(s), tracker on '
                               f'{self.driver.tracker_topic}')

    def now(self) -> float:
        """The host's monotonic time (s)."""
        return time.monotonic() - self.host_start

    # --- inputs -------------------------------------------------------------------------

    def on_episode(self, msg: String) -> None:
        """As the world node; an episode of more robots than links is refused, naming them."""
        try:
            announcement = Announcement.from_json(msg.data)
        except ContractError:
            announcement = None  # the world node says why
        if announcement is not None and not announcement.shutdown and \
                announcement.population > len(self.link_of) and \
                (self.announcement is None or self.announcement.key != announcement.key):
            self.announcement, self.episode = announcement, announcement.episode
            self.fail(f'episode {self.episode} rejected: {announcement.population} robots '
                      f'announced, but driver.links names {len(self.link_of)}', fatal=False)
            return
        super().on_episode(msg)

    def poll_links(self) -> None:
        """Read every link: fresh telemetry updates the robot's IR. Between episodes, a stop
        to every robot every KEEP_ALIVE s, so the links are heard before step 0."""
        if self.state is not WorldState.RUNNING and self.now() >= self.next_keep_alive:
            self.next_keep_alive = self.now() + KEEP_ALIVE
            for i, transport in enumerate(self.link_of):
                self.send(transport, i, self.fleet.command(i, 0, 0, False))
        population = self.world.population
        for url, transport in self.transports.items():
            decoder = self.decoders[url]
            while data := transport.receive(0.0):
                frames = list(decoder.feed(data))
                if transport.datagrams:
                    frames += decoder.flush()
                for frame in frames:
                    telemetry = self.fleet.receive(frame, self.now())
                    if telemetry is not None and frame.robot < population:
                        self.world.set_ir(frame.robot, np.array(telemetry.ir))
        if self.state is not WorldState.RUNNING:
            self.log_events()  # a running world logs them each tick

    def on_tracker(self, msg: PoseArray) -> None:
        """The tracker's poses: robot i at index i, a NaN position where it was not seen."""
        if msg.header.frame_id != 'world':
            self.tracker_frames += 1
            self.get_logger().error(f'tracker poses in frame {msg.header.frame_id!r}, not '
                                    "'world': ignored", throttle_duration_sec=5.0)
            return
        rows = np.array([[p.position.x, p.position.y, p.orientation.z, p.orientation.w]
                         for p in msg.poses], dtype=np.float64).reshape(-1, 4)
        poses = np.column_stack([rows[:, :2], yaw_from_quaternion(rows[:, 2], rows[:, 3])])
        if not self.world.population:
            return
        valid = self.world.track(poses)
        self.fleet.tracked(valid, self.now())

    # --- stepping -----------------------------------------------------------------------

    def on_realtime_tick(self) -> None:
        """Step as many steps as the host clock says are due (none if the tick came early,
        at most MAX_CATCH_UP), holding the faulty robots, then send every robot its
        command."""
        now = self.now()
        period = self.params.step_period
        if self.world.steps == 0 or self.step_origin is None:
            self.step_origin = now - period
        due = int((now - self.step_origin) / period) - self.world.steps
        if due > MAX_CATCH_UP:  # a stall longer than 10 steps: sim time falls behind
            self.step_origin += (due - MAX_CATCH_UP) * period
            self.stalls += 1
            self.get_logger().warning(f'step {self.world.steps}: {due} steps due after a '
                                      f'stall; {MAX_CATCH_UP} taken, sim time is '
                                      f'{(due - MAX_CATCH_UP) * period:.3f} s behind the host '
                                      'clock from here', throttle_duration_sec=5.0)
        for _ in range(max(0, min(due, MAX_CATCH_UP))):
            held = self.fleet.held(now)[:self.world.population]
            self.world.held = held
            self.fleet.count_held(held)
            super().on_realtime_tick()
            if self.state is not WorldState.RUNNING:
                break
        self.log_events()
        self.send_commands(stop=self.state is not WorldState.RUNNING)
        if self.state is WorldState.FINISHED:
            self.write_driver_record()

    def log_events(self) -> None:
        """Log the faults the fleet found since the last call."""
        for event in self.fleet.take_events():
            self.get_logger().warning(event)

    def send_commands(self, stop: bool = False) -> None:
        """Each robot's latest command (or a stop) as a link frame."""
        linear, angular = self.world.commanded
        cleaning = self.world.cleaning
        separation, full = self.mona.wheel_separation, self.driver.full_speed
        for i in range(self.world.population):
            if stop:
                frame = self.fleet.command(i, 0, 0, False)
            else:
                left, right = twist_to_wheels(float(linear[i]), float(angular[i]), separation)
                frame = self.fleet.command(i, to_permille(left, full), to_permille(right, full),
                                           bool(cleaning[i]))
            self.send(self.link_of[i], i, frame)

    def send(self, transport: Transport, robot: int, frame: bytes) -> None:
        """Send a frame; a port that went away makes the robot silent, and is logged."""
        try:
            transport.send(frame)
        except OSError as error:
            self.get_logger().error(f'robot {robot}: sending failed: {error}',
                                    throttle_duration_sec=5.0)

    # --- records ------------------------------------------------------------------------

    def publish_status(self) -> None:
        """/world/status with the held robots listed absent, and /driver/status."""
        held = self.world.held if isinstance(self.world, TrackedWorld) else ()
        if len(held) and len(held) == len(self.lockstep.absent):
            self.lockstep.absent |= held
        super().publish_status()
        if hasattr(self, 'driver_pub'):
            self.driver_pub.publish(String(data=json.dumps(self.driver_record())))

    def driver_record(self) -> dict:
        """What the driver counted: per robot the link's frames and the faults."""
        rejected = {url: dict(decoder.rejected, garbage=decoder.garbage)
                    for url, decoder in self.decoders.items()}
        return {'episode': self.episode, 'time_ns': self.time_ns, 'robots':
                self.fleet.counters(), 'rejected': rejected,
                'tracker_wrong_frame': self.tracker_frames, 'stalls': self.stalls}

    def write_driver_record(self) -> None:
        """<output_dir>/episode_<k>/driver.json: the fault counts of the episode."""
        if not self.options.output_dir:
            return
        folder = Path(self.options.output_dir) / f'episode_{self.episode}'
        folder.mkdir(parents=True, exist_ok=True)
        partial = folder / (DRIVER_FILE + '.partial')
        partial.write_text(json.dumps(self.driver_record(), indent=1))
        os.replace(partial, folder / DRIVER_FILE)

    def close(self) -> None:
        """Stop every robot and close the ports (before the node's teardown)."""
        if self.world.population:
            self.send_commands(stop=True)
        self.close_ports()

    def close_ports(self) -> None:
        """Close the ports opened so far."""
        for transport in self.transports.values():
            transport.close()


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``driver_node [--ros-args ...]``; exits when the run is over."""
    argv = list(sys.argv if args is None else args)
    parse_node_args(node_parser('driver_node', __doc__.split('\n')[0], sections={
        '': WorldNodeParams, 'world.': WorldParams, 'mona.': MonaParams,
        'sensing.': SensingParams, 'driver.': DriverParams}), argv[1:])
    rclpy.init(args=argv)
    return run(DriverNode, 'driver')


if __name__ == '__main__':
    sys.exit(main())

"""The driver node in this process, its robots played by UDP sockets of the test, and its
command lines as real processes (bad input: exit 2, one line; SIGTERM: a clean stop)."""

from __future__ import annotations

import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseArray
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import String

from mona_controller.contract import Announcement, WorldStatus
from mona_controller.link.frame import Decoder, Frame
from mona_controller.link.payloads import COMMAND, TELEMETRY, Command, Telemetry
from mona_controller.ros import qos
from swarm_world.driver.firmware import build_images
from swarm_world.ros.driver_node import TRACKER_QOS, DriverNode
from swarm_world.ros.world_messages import PoseArrayFiller

from harness import REPO

pytestmark = pytest.mark.ros

PARAMS = REPO / 'ros_ws' / 'config' / 'mona_swarm.yaml'


@pytest.fixture
def robots():
    """Two UDP sockets standing for two robots' links."""
    socks = []
    for _ in range(2):
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.bind(('127.0.0.1', 0))
        sock.settimeout(0.0)
        socks.append(sock)
    yield socks
    for sock in socks:
        sock.close()


class Operator(Node):
    """Announces episodes, publishes tracker poses, keeps the world's statuses."""

    def __init__(self, **kwargs) -> None:
        super().__init__('operator', **kwargs)
        self.episode_pub = self.create_publisher(String, qos.EPISODE, qos.EPISODE_QOS)
        self.tracker_pub = self.create_publisher(PoseArray, '/tracker/poses', TRACKER_QOS)
        self.statuses: list[WorldStatus] = []
        self.create_subscription(String, qos.STATUS,
                                 lambda m: self.statuses.append(WorldStatus.from_json(m.data)),
                                 qos.STATUS_QOS)

    def announce(self, population: int, episode: int = 0) -> None:
        self.episode_pub.publish(String(data=Announcement(
            episode, seed=1, population=population, duration=5.0, start_ns=0,
            poses=tuple((0.5 + 0.3 * i, 0.5, 0.0) for i in range(population))).to_json()))


@pytest.fixture
def driver(executor, robots):
    links = ','.join(f'udp:127.0.0.1:{sock.getsockname()[1]}' for sock in robots)
    node = DriverNode(context=executor.context, parameter_overrides=[
        Parameter('driver.links', value=links)])
    operator = Operator(context=executor.context)
    executor.add_node(node)
    executor.add_node(operator)
    yield node, operator
    node.close_ports()


def received(sock: socket.socket) -> list[tuple[Frame, tuple]]:
    """The frames that reached a robot's socket so far, with the sender's address."""
    out = []
    while True:
        try:
            data, address = sock.recvfrom(2048)
        except BlockingIOError:
            return out
        decoder = Decoder()
        out += [(frame, address) for frame in [*decoder.feed(data), *decoder.flush()]]


def test_between_episodes_every_robot_gets_stops_and_its_telemetry_is_taken(
        driver, robots, spin_until):
    node, operator = driver
    frames: list[list] = [[], []]
    spin_until(lambda: all(frames[i].extend(received(s)) or frames[i]
                           for i, s in enumerate(robots)), timeout=10, what='keep-alives')
    for robot, got in enumerate(frames):
        frame, address = got[0]
        assert (frame.kind, frame.robot, frame.nonce) == (COMMAND, robot, node.fleet.host_nonce)
        assert Command.decode(frame.payload) == Command(0, 0, False)
    # Robot 1 answers with telemetry, as the firmware does, to where the commands came from.
    ir = (1023, 800, 500, 1023, 1023)
    robots[1].sendto(Frame(1, 0, 77, TELEMETRY, Telemetry(ir, 0, 0, 3600, 0, 0, 0).encode())
                     .encode(), frames[1][0][1])
    spin_until(lambda: node.fleet.robots[1].stream.received == 1, timeout=10,
               what='telemetry taken')
    assert node.fleet.robots[1].telemetry.ir == ir
    assert node.fleet.robots[0].stream.received == 0


def test_an_episode_of_more_robots_than_links_is_refused_naming_them(driver, spin_until):
    node, operator = driver
    spin_until(lambda: operator.episode_pub.get_subscription_count() > 0, what='matched')
    operator.announce(3)
    spin_until(lambda: any(s.state.value == 'failed' for s in operator.statuses),
               what='the episode refused')
    failed = [s for s in operator.statuses if s.state.value == 'failed'][-1]
    assert '3 robots announced, but driver.links names 2' in failed.error


def test_tracked_poses_move_the_robots_and_another_frame_is_refused(driver, spin_until):
    node, operator = driver
    spin_until(lambda: operator.episode_pub.get_subscription_count() > 0, what='matched')
    operator.announce(2)
    spin_until(lambda: node.world.population == 2, what='episode reset')
    assert node.world.poses[:, 0].tolist() == [0.5, 0.8]  # the announced poses, until seen
    spin_until(lambda: operator.tracker_pub.get_subscription_count() > 0, what='tracker')
    camera = PoseArrayFiller('camera').fill(np.array([[2.0, 2.0, 0.0], [2.1, 2.0, 0.0]]), 0)
    operator.tracker_pub.publish(camera)
    spin_until(lambda: node.tracker_frames == 1, what='the camera frame refused')
    assert node.world.poses[:, 0].tolist() == [0.5, 0.8]
    seen = PoseArrayFiller().fill(np.array([[1.5, 1.0, 0.5], [np.nan, np.nan, np.nan]]), 0)
    operator.tracker_pub.publish(seen)
    spin_until(lambda: node.world.poses[0, 0] == 1.5, what='robot 0 tracked')
    assert node.world.poses[0, 2] == pytest.approx(0.5)
    assert node.world.poses[1].tolist() == [0.8, 0.5, 0.0]  # NaN: not seen, kept
    assert node.fleet.robots[0].seen is not None and node.fleet.robots[1].seen is None


def run(command: list[str], env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=120)


def test_bad_input_exits_2_with_one_line(ros_env):
    bin_dir = REPO / '.venv' / 'bin'
    result = run([str(bin_dir / 'driver_node'), '--ros-args', '--params-file', str(PARAMS)],
                 ros_env)
    assert result.returncode == 2 and 'driver.links is empty' in result.stderr + result.stdout
    assert 'Traceback' not in result.stderr
    result = run([str(bin_dir / 'driver_node'), '--ros-args', '--params-file', str(PARAMS),
                  '-p', 'driver.links:=udp:nowhere'], ros_env)
    assert result.returncode == 2 and "'udp:nowhere' is not 'udp:HOST:PORT'" in (
        result.stderr + result.stdout)
    result = run([str(bin_dir / 'driver_hil'), '--robots', '2', '--params-file',
                  '/no/such.yaml'], ros_env)
    assert result.returncode == 2 and 'driver_hil: /no/such.yaml' in result.stderr
    assert 'Traceback' not in result.stderr
    result = run([str(bin_dir / 'driver_hil'), '--robots', '2', '--params-file', str(PARAMS),
                  '--loss', '2'], ros_env)
    assert result.returncode == 2 and '--loss must be within 0..1' in result.stderr


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_the_harness_stops_cleanly_on_a_signal(processes, tmp_path, stop):
    hil = processes.spawn([str(REPO / '.venv' / 'bin' / 'driver_hil'), '--robots', '3',
                           '--params-file', str(PARAMS), '--out', str(tmp_path / 'hil')],
                          'hil')
    log = tmp_path / 'hil' / 'driver_node.log'
    deadline = time.monotonic() + 60
    while 'waiting for an episode' not in (log.read_text() if log.exists() else ''):
        assert time.monotonic() < deadline and hil.poll() is None, processes.log('hil')
        time.sleep(0.2)
    children = subprocess.run(['pgrep', '-f', str(tmp_path / 'hil')], capture_output=True,
                              text=True).stdout.split()
    assert len(children) >= 4  # three monasim processes and the driver (and the harness)
    hil.send_signal(stop)
    assert hil.wait(timeout=30) == 0, processes.log('hil')
    left = subprocess.run(['pgrep', '-f', str(tmp_path / 'hil')], capture_output=True,
                          text=True).stdout.split()
    assert left == [], left
    assert 'driver_hil: the firmwares ran' in processes.log('hil')


def test_the_driver_speaks_serial_to_a_firmware_on_a_pty_shared_by_two_ids(
        executor, spin_until, tmp_path):
    """One firmware (robot 1) on a pseudo-terminal that the links of robots 0 and 1 share, as
    robots on one radio do: the driver's frames reach it and its telemetry is robot 1's."""
    if shutil.which('avr-gcc') is None or not Path('/usr/include/simavr/sim_avr.h').exists():
        pytest.skip('needs the firmware tools: make firmware-tools')
    images, monasim = build_images(2, tmp_path / 'firmware')
    process = subprocess.Popen([str(monasim), str(images[1]), '--pty', '8'],
                               stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None
        line = ''
        while not line.startswith('P '):  # simavr's own lines first
            line = process.stdout.readline()
            assert line, 'monasim ended without a pty'
        pty = line.split()[1]
        node = DriverNode(context=executor.context, parameter_overrides=[
            Parameter('driver.links', value=f'{pty},{pty}')])
        executor.add_node(node)
        assert len(node.transports) == 1  # one port for both robots
        spin_until(lambda: node.fleet.robots[1].stream.received >= 30, timeout=20,
                   what='30 telemetry frames over the pty')
        robot1 = node.fleet.robots[1]
        assert robot1.telemetry.ack > 0  # it applied the driver's stops (its own id)
        assert robot1.stream.lost == 0 and robot1.telemetry.rx_rejected == 0
        assert node.fleet.robots[0].stream.received == 0  # nobody answers as robot 0
        decoder = node.decoders[pty]
        assert decoder.rejected['bad_crc'] == 0 and decoder.rejected['truncated'] == 0
        node.close_ports()
    finally:
        process.kill()
        process.wait(timeout=10)

"""The emulated robots of ``driver_hil`` (docs/driver.md, "Hardware in the loop"), without ROS.

Each robot's firmware image (the very image one would flash, ``make -C firmware/mona
ROBOT_ID=i``) runs in its own ``monasim`` process (firmware/sim) paced to the wall clock
(:class:`~swarm_world.driver.firmware.Firmware`, with its build); :class:`EmulatedArena` moves
the robots with the world's own physics from the wheel outputs (PWM and direction registers
through the deadband map), feeds each firmware its IR (the world's beams at the true poses,
through the calibration, as ADC voltages) and its encoder edges, carries the link over UDP
(one port per robot, with settable latency, loss and duplication: :class:`DelayLine`) and
makes the tracker's poses (with settable latency and noise). Faults are scheduled
(:class:`Window`): a reboot, a silent radio, a tracker dropout, a battery sag. The command
itself, which starts the driver node and publishes the tracker, is :mod:`swarm_world.ros.hil`.
"""

from __future__ import annotations

import argparse
import heapq
import math
import random
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mona_controller.keys import moved_keys, relocate
from mona_controller.mappings import from_mapping
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError
from swarm_world.driver.calibration import IrCalibration
from swarm_world.driver.firmware import Firmware, HilError
from swarm_world.driver.params import DriverParams
from swarm_world.driver.wheels import pwm_to_permille
from swarm_world.params import WorldParams
from swarm_world.physics import Physics
from swarm_world.sensing.ir import proximity

#: The ADC channel of each IR sensor, right to left (docs/link.md, "Pins").
IR_CHANNELS = (3, 2, 1, 0, 7)
#: Simulated microseconds per emulator tick.
TICK_US = 20_000
#: The longest physics step (s), and the longest wall gap between ticks that is moved.
MAX_DT, MAX_GAP = 0.02, 0.5
#: The battery's ADC channel and divider (firmware/mona/src/pins.h, sensors.h).
BATTERY_CHANNEL, BATTERY_DIVIDER = 6, 2
#: An emulated robot's battery (one Li-ion cell, charged).
BATTERY_MV = 3900
#: Encoder edges per metre of wheel travel: MonaMk2's 980 ticks per revolution (docs/link.md)
#: on a 32 mm wheel (a guess; unverified on the classic Mona).
EDGES_PER_METRE = 980 / (math.pi * 0.032)


@dataclass(order=True)
class Delayed:
    """Bytes (or a pose array) due at a wall time."""

    due: float
    order: int
    data: object = field(compare=False)


class DelayLine:
    """A link or tracker with latency, loss and duplication (seeded)."""

    def __init__(self, latency: float, loss: float, duplicate: float, rng: random.Random):
        self.latency, self.loss, self.duplicate, self.rng = latency, loss, duplicate, rng
        self.queue: list[Delayed] = []
        self.count = 0
        self.lost = self.duplicated = 0

    def put(self, data: object, now: float) -> None:
        """Send ``data``: it arrives ``latency`` later, unless lost; perhaps twice."""
        if self.loss and self.rng.random() < self.loss:
            self.lost += 1
            return
        copies = 2 if self.duplicate and self.rng.random() < self.duplicate else 1
        self.duplicated += copies - 1
        for _ in range(copies):
            self.count += 1
            heapq.heappush(self.queue, Delayed(now + self.latency, self.count, data))

    def due(self, now: float) -> list[Any]:
        """What arrives by ``now``, in order."""
        out = []
        while self.queue and self.queue[0].due <= now:
            out.append(heapq.heappop(self.queue).data)
        return out


@dataclass
class Window:
    """A fault of one robot from ``start`` for ``length`` s of episode wall time."""

    robot: int
    start: float
    length: float = 0.0

    def covers(self, robot: int, t: float) -> bool:
        """Whether the fault is on for ``robot`` at ``t``."""
        return robot == self.robot and self.start <= t < self.start + self.length


def parse_battery(text: str) -> tuple[Window, int]:
    """``ROBOT@START=MV``: the robot's battery reads MV from START on."""
    when, _, mv = text.partition('=')
    if not mv.isdigit():
        raise argparse.ArgumentTypeError(f'{text!r}: expected ROBOT@START=MV, e.g. 2@5=3300')
    return parse_window(when), int(mv)


def parse_window(text: str) -> Window:
    """``ROBOT@START[+LENGTH]`` (seconds after the episode's announcement)."""
    try:
        robot, _, when = text.partition('@')
        start, _, length = when.partition('+')
        return Window(int(robot), float(start), float(length or 0.0))
    except ValueError:
        raise argparse.ArgumentTypeError(f'{text!r}: expected ROBOT@START[+LENGTH], e.g. '
                                         '1@10+3') from None


def load_sections(path: Path) -> tuple[WorldParams, MonaParams, DriverParams]:
    """The world, mona and driver sections of a parameter file."""
    try:
        document = yaml.safe_load(path.read_text())
        parameters = relocate(document['/**']['ros__parameters'],
                              moved_keys(MonaParams, 'mona.'))
        return (from_mapping(WorldParams, parameters.get('world'), 'world.'),
                from_mapping(MonaParams, parameters.get('mona'), 'mona.'),
                from_mapping(DriverParams, parameters.get('driver'), 'driver.'))
    except (OSError, yaml.YAMLError, KeyError, TypeError) as error:
        raise HilError(f'{path}: not a parameter file with a /** ros__parameters section '
                       f'({error})') from None
    except ParameterError as error:
        raise HilError(f'{path}: {error}') from None


class EmulatedArena:
    """The emulated robots: the firmwares, their physics, their links and the tracker."""

    def __init__(self, options: argparse.Namespace, world: WorldParams, mona: MonaParams,
                 driver: DriverParams, firmwares: list[Firmware]) -> None:
        self.options, self.world, self.mona = options, world, mona
        self.full_speed = driver.full_speed
        self.calibration = IrCalibration(driver.ir_calibration)
        self.firmwares = firmwares
        self.bearings = mona.ir_bearings()
        self.arena = world.arena()
        n = len(firmwares)
        rng = random.Random(options.seed)
        self.noise = np.random.default_rng(options.seed)
        self.sockets = []
        for _ in range(n):
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.bind(('127.0.0.1', 0))
            sock.setblocking(False)
            self.sockets.append(sock)
        self.host: list[tuple[str, int] | None] = [None] * n  # the driver's address
        link = (options.latency, options.loss, options.duplicate)
        self.down = [DelayLine(*link, rng) for _ in range(n)]  # host -> robot
        self.up = [DelayLine(*link, rng) for _ in range(n)]  # robot -> host
        self.tracker_line = DelayLine(options.tracker_latency, 0.0, 0.0, rng)
        #: Telemetry frames each firmware made while its radio was silent (never sent).
        self.unsent = [0] * n
        self.physics: Physics | None = None
        self.episode_wall: float | None = None  # wall time of the latest announcement
        self.adc_sent: list[tuple[int, ...]] = [()] * n
        self.edges = np.zeros((n, 2))
        self.rebooted: set[int] = set()
        self.last_tracker = 0.0
        self.last_tick: float | None = None
        # Load the compiled kernels now: a first call in a tick would stall the firmwares.
        warm = np.array([[0.5, 0.5, 0.0], [0.7, 0.5, 0.0]])
        proximity(warm, mona.body_radius, self.bearings, mona.ir_range, world.arena_side,
                  self.arena.packed)
        Physics(world.arena_side, mona.body_radius, warm, world.collision_slop,
                self.arena.obstacles).step(np.zeros(2), np.zeros(2), TICK_US / 1e6)

    def ports(self) -> list[int]:
        """The UDP port of each robot's link."""
        return [sock.getsockname()[1] for sock in self.sockets]

    def place(self, poses: np.ndarray) -> None:
        """Put the robots at the announced poses (an operator's job)."""
        self.physics = Physics(self.world.arena_side, self.mona.body_radius, poses,
                               self.world.collision_slop, self.arena.obstacles)
        self.episode_wall = time.monotonic()
        self.rebooted.clear()

    def faulty(self, faults: list[Window], robot: int) -> bool:
        """Whether one of ``faults`` is on for ``robot`` now."""
        if self.episode_wall is None:
            return False
        t = time.monotonic() - self.episode_wall
        return any(window.covers(robot, t) for window in faults)

    def battery(self, robot: int) -> int:
        """The robot's battery now (mV): the last ``--battery`` setting due, else charged."""
        mv = BATTERY_MV
        if self.episode_wall is not None:
            t = time.monotonic() - self.episode_wall
            for window, level in self.options.battery:
                if window.robot == robot and t >= window.start:
                    mv = level
        return mv

    def tick(self, now: float) -> None:
        """One emulator tick: links in, firmwares run TICK_US, robots move, links out."""
        n = len(self.firmwares)
        poses = self.physics.poses if self.physics is not None else None
        ranges = (proximity(poses, self.mona.body_radius, self.bearings, self.mona.ir_range,
                            self.world.arena_side, self.arena.packed)[0]
                  if poses is not None else np.full((n, len(self.bearings)), np.inf))
        speeds = np.zeros((n, 2))
        for i, firmware in enumerate(self.firmwares):
            silent = self.faulty(self.options.silence, i)
            while True:
                try:
                    data, address = self.sockets[i].recvfrom(2048)
                except BlockingIOError:
                    break
                self.host[i] = address
                if not silent:
                    self.down[i].put(data, now)
            commands = [f'send {bytes(data).hex()}' for data in self.down[i].due(now)]
            if self.episode_wall is not None and i not in self.rebooted and any(
                    w.robot == i and time.monotonic() - self.episode_wall >= w.start
                    for w in self.options.reboot):
                self.rebooted.add(i)
                commands.append('reset')
            adc = (*self.calibration.millivolts(self.calibration.to_adc(ranges[i])),
                   self.battery(i) // BATTERY_DIVIDER)
            if adc != self.adc_sent[i]:
                commands += [f'adc {ch} {mv}' for ch, mv in
                             zip((*IR_CHANNELS, BATTERY_CHANNEL), adc)]
                self.adc_sent[i] = adc
            for side, column in (('L', 0), ('R', 1)):
                whole = int(self.edges[i, column])
                if whole > 0:
                    commands.append(f'enc {side} {whole} {max(1, TICK_US // (whole + 1))}')
                    self.edges[i, column] -= whole
            commands.append(f'run {TICK_US}')
            firmware.send(commands)
        # The firmwares run their ticks in parallel (one process each); then take the results.
        for i, firmware in enumerate(self.firmwares):
            silent = self.faulty(self.options.silence, i)
            firmware.collect()
            pwm_l, dir_l, pwm_r, dir_r, _ = firmware.pwm
            speeds[i] = [pwm_to_permille(pwm_l, bool(dir_l), self.options.deadband),
                         pwm_to_permille(pwm_r, bool(dir_r), self.options.deadband)]
            for frame in firmware.frames():
                if silent:
                    self.unsent[i] += 1
                else:
                    self.up[i].put(frame, now)
            host = self.host[i]
            if host is not None:
                for frame in self.up[i].due(now):
                    self.sockets[i].sendto(frame, host)
        speeds *= self.full_speed / 1000.0
        # The robots move in wall time, as real ones do, also when the firmwares lag it (a
        # loaded machine): the wheels hold their PWM between ticks. Sub-steps of at most
        # MAX_DT keep the collisions sound; a stall longer than MAX_GAP is not made up.
        dt = TICK_US / 1e6 if self.last_tick is None else min(now - self.last_tick, MAX_GAP)
        self.last_tick = now
        self.edges += np.abs(speeds) * dt * EDGES_PER_METRE
        if self.physics is not None and dt > 0:
            left, right = speeds[:, 0], speeds[:, 1]
            linear, angular = (left + right) / 2, (right - left) / self.mona.wheel_separation
            steps = max(1, math.ceil(dt / MAX_DT))
            for _ in range(steps):
                self.physics.step(linear, angular, dt / steps)

    def tracker_poses(self, now: float) -> np.ndarray | None:
        """The tracker's view now, with noise and dropouts (NaN rows), or None between
        frames (at ``--tracker-rate``)."""
        if self.physics is None or now - self.last_tracker < 1.0 / self.options.tracker_rate:
            return None
        self.last_tracker = now
        poses = self.physics.poses.copy()
        if self.options.tracker_noise:
            poses[:, :2] += self.noise.normal(0.0, self.options.tracker_noise, (len(poses), 2))
        for i in range(len(poses)):
            if self.faulty(self.options.dropout, i):
                poses[i] = np.nan
        return poses

    def close(self) -> None:
        """Stop the firmwares, close the sockets."""
        for firmware in self.firmwares:
            firmware.stop()
        for sock in self.sockets:
            sock.close()

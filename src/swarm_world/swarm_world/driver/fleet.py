"""Each robot's link as the driver sees it: telemetry in, wheel commands out, and the faults.

Pure (no ROS, no sockets): the driver node feeds it decoded frames, tracker sightings and the
host's monotonic time, and asks it which robots to hold still. A robot is **held** (stopped,
its cleaner off, absent in /world/status) while it is silent (no fresh telemetry for
``silent_after`` s, or none yet) or lost by the tracker (no valid pose for
``tracker_timeout`` s); it is released as soon as both come back. Every fault is counted per
robot (:meth:`Fleet.counters`), so the record says what happened (docs/reliability.md,
"Driver faults").
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from mona_controller.link.frame import Frame
from mona_controller.link.payloads import COMMAND, TELEMETRY, Command, PayloadError, Telemetry
from mona_controller.link.sequence import FRESH, REBOOT, Counter16, Stream


@dataclasses.dataclass
class RobotLink:
    """One robot's link state and fault counts."""

    robot: int
    stream: Stream = dataclasses.field(default_factory=Stream)
    commands: Counter16 = dataclasses.field(default_factory=Counter16)
    telemetry: Telemetry | None = None
    heard: float | None = None  #: host time of the latest fresh telemetry
    seen: float | None = None  #: host time of the latest valid tracked pose
    silent: bool = True
    lost: bool = True  #: by the tracker
    silences: int = 0  #: times it went silent after being heard
    dropouts: int = 0  #: times the tracker lost it after seeing it
    held_steps: int = 0  #: steps it was held still
    malformed: int = 0  #: telemetry frames whose payload did not decode
    low: bool = False  #: its battery reads below the threshold
    never_said: bool = True  #: held before it was ever heard and seen, not yet logged
    low_battery: int = 0  #: times its battery fell below the threshold
    foreign: int = 0  #: frames not telemetry or from an id outside the episode


class Fleet:
    """The links to one episode's robots.

    Args:
        population: robots ``0 .. population - 1``.
        host_nonce: this host boot's nonce, stamped on every command (a robot takes a new
            nonce as a new host and accepts its sequence afresh).
        silent_after: seconds without fresh telemetry after which a robot is silent.
        tracker_timeout: seconds without a valid tracked pose after which it is lost.
        battery_low: mV below which a robot's battery counts as low (counted and logged, the
            robot not held: a slow robot is still a robot).
    """

    def __init__(self, population: int, host_nonce: int, silent_after: float,
                 tracker_timeout: float, battery_low: int = 0) -> None:
        self.robots = [RobotLink(i) for i in range(population)]
        self.host_nonce = host_nonce & 0xFFFF
        self.silent_after = silent_after
        self.tracker_timeout = tracker_timeout
        self.battery_low = battery_low
        self.events: list[str] = []  #: what happened since the last :meth:`take_events`

    def receive(self, frame: Frame, now: float) -> Telemetry | None:
        """Account for a frame from the robots; its telemetry if it is fresh (new, not a
        duplicate or a late frame from before a reboot), else None."""
        if frame.kind != TELEMETRY or not 0 <= frame.robot < len(self.robots):
            if 0 <= frame.robot < len(self.robots):
                self.robots[frame.robot].foreign += 1
            return None
        link = self.robots[frame.robot]
        verdict = link.stream.observe(frame.seq, frame.nonce)
        if verdict not in FRESH:  # a duplicate, or stale from before a reboot
            return None
        try:
            telemetry = Telemetry.decode(frame.payload)
        except PayloadError:
            link.malformed += 1
            return None
        if verdict == REBOOT:
            self.events.append(f'robot {link.robot} rebooted (boot nonce {frame.nonce})')
        link.telemetry, link.heard = telemetry, now
        low = telemetry.battery_mv < self.battery_low
        if low and not link.low:
            link.low_battery += 1
            self.events.append(f'robot {link.robot} battery low: {telemetry.battery_mv} mV < '
                               f'{self.battery_low} mV')
        link.low = low
        return telemetry

    def tracked(self, valid: np.ndarray, now: float) -> None:
        """The tracker saw the robots where ``valid`` [N] is true at host time ``now``."""
        for i in np.flatnonzero(valid[:len(self.robots)]):
            self.robots[i].seen = now

    def held(self, now: float) -> np.ndarray:
        """[N] the robots to hold still now (silent or lost), counting each new fault."""
        held = np.zeros(len(self.robots), dtype=bool)
        for link in self.robots:
            silent = link.heard is None or now - link.heard > self.silent_after
            lost = link.seen is None or now - link.seen > self.tracker_timeout
            if silent and not link.silent and link.heard is not None:
                link.silences += 1
                self.events.append(f'robot {link.robot} silent: no telemetry for '
                                   f'{self.silent_after:g} s; stopped, absent')
            if lost and not link.lost and link.seen is not None:
                link.dropouts += 1
                self.events.append(f'robot {link.robot} lost by the tracker for '
                                   f'{self.tracker_timeout:g} s; stopped, absent')
            if (silent or lost) and link.never_said and (link.heard is None
                                                          or link.seen is None):
                link.never_said = False
                missing = ' and no '.join(name for name, absent in (
                    ('telemetry', link.heard is None), ('tracked pose', link.seen is None))
                    if absent)
                self.events.append(f'robot {link.robot} held: no {missing} yet')
            if link.silent and not silent or link.lost and not lost:
                if not silent and not lost:
                    self.events.append(f'robot {link.robot} back: telemetry and pose')
            link.silent, link.lost = silent, lost
            held[link.robot] = silent or lost
        return held

    def count_held(self, held: np.ndarray) -> None:
        """One step was taken with ``held`` [N] robots held still."""
        for i in np.flatnonzero(held):
            self.robots[i].held_steps += 1

    def command(self, robot: int, left: int, right: int, cleaner: bool) -> bytes:
        """The encoded command frame for ``robot`` (wheels in per-mille)."""
        link = self.robots[robot]
        return Frame(robot, link.commands.next(), self.host_nonce, COMMAND,
                     Command(left, right, cleaner).encode()).encode()

    def take_events(self) -> list[str]:
        """The fault events since the last call (for the log)."""
        events, self.events = self.events, []
        return events

    def counters(self) -> list[dict[str, Any]]:
        """Per robot: the link's frame counts and the faults, for the record."""
        rows = []
        for link in self.robots:
            stream = link.stream
            rows.append({
                'robot': link.robot, 'received': stream.received, 'lost': stream.lost,
                'duplicated': stream.duplicated, 'reordered': stream.reordered,
                'reboots': stream.reboots, 'stale': stream.stale, 'malformed': link.malformed,
                'foreign': link.foreign, 'silences': link.silences, 'dropouts': link.dropouts,
                'held_steps': link.held_steps, 'low_battery': link.low_battery,
                'silent': link.silent, 'lost_by_tracker': link.lost,
                'battery_mv': None if link.telemetry is None else link.telemetry.battery_mv,
                'rx_rejected': None if link.telemetry is None else link.telemetry.rx_rejected})
        return rows

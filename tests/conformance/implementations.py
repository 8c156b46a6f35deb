"""The world-side implementations the conformance suite knows by name.

One line each: the command that starts the implementation as a black box, for the robots
``/mona_0 .. /mona_{population-1}``, on the suite's private ROS domain, with the suite's
parameter file. Placeholders, filled by the suite: ``{domain}`` (ROS_DOMAIN_ID, also set in
the environment), ``{params}`` (a ROS 2 parameter file with every section, the shipped
ros_ws/config/mona_swarm.yaml), ``{population}`` (the most robots an episode of the suite
announces). ``--world-cmd NAME`` picks one; any other ``--world-cmd`` text is taken as a
command line of its own (tests/conformance/README.md).
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Implementation:
    """A world-side implementation and what the suite may expect of it."""

    command: str  #: a shell-free command line (split on spaces), with the placeholders above
    mode: str = 'lockstep'  #: 'lockstep' or 'realtime': the Stepping rules it follows
    #: How far its poses and readings may stray from exact geometry (m): 0-ish for a
    #: simulation, a tracker's and an IR calibration's error for real robots.
    pose_tolerance: float = 1e-6
    range_tolerance: float = 1e-4
    #: How old (s) a reading may be against the poses of its stamp: 0 for a simulation; for
    #: real robots, their telemetry's trip over the link and through a busy host.
    reading_age: float = 0.0
    cue_tolerance: float = 2.5  #: cue units (a cell's value rounded to mono8)
    #: Its publishing periods of sim time (the world node's defaults; docs/interfaces.md).
    status_period: float = 1.0
    map_period: float = 1.0
    #: Needs the firmware's Debian tools (gcc-avr, simavr: make firmware-tools).
    needs_firmware: bool = False
    #: Its /world/status counts `cleaning_events` (a driver may leave the key out; a command
    #: line of your own is held to the count only where it gives the key).
    counts_cleaning_events: bool = False
    #: The `absent_after` its command line sets (steps): the rules on absent robots wait for
    #: it. A realtime driver on emulated robots needs more than the world node's 3: on a busy
    #: 2-core machine its link round (reading out, answer back) took over 3 steps of 32 ms,
    #: so answered robots counted stale, held still and cleaned nothing.
    absent_after: int = 3


#: name -> implementation; the first is the default.
IMPLEMENTATIONS: dict[str, Implementation] = {
    # The simulated world node; a short deadline so the absent-robot rules cost little time.
    'world': Implementation('world_node --ros-args --params-file {params} '
                            '-p lockstep_deadline:=0.5 -p absent_after:=3',
                            counts_cleaning_events=True),
    # The same node stepping on the wall clock, as a driver for real robots does.
    'world-realtime': Implementation('world_node --ros-args --params-file {params} '
                                     '-p mode:=realtime -p absent_after:=3', mode='realtime',
                                     counts_cleaning_events=True),
    # The driver for real Monas (docs/driver.md) on emulated ones: the firmware image in
    # simavr per robot, moved by the world's physics, and a simulated tracker. Ranges come
    # back through the robots' 10-bit IR ADC and the driver's calibration table (5 mm), a
    # link round or more later than the tracked pose of their stamp: on a busy 2-core machine
    # the emulation ran at 26 % of real time and a reading matched the poses of 150 ms
    # before its stamp; any pose of the last 0.5 s will do.
    'driver': Implementation('driver_hil --robots {population} --params-file {params} '
                             '--domain {domain} -- -p absent_after:=10', mode='realtime',
                             range_tolerance=5e-3, reading_age=0.5, needs_firmware=True,
                             absent_after=10),
}


def resolve(text: str | None) -> tuple[str, Implementation]:
    """``--world-cmd``: a name of :data:`IMPLEMENTATIONS`, or a command line (lockstep, the
    simulation's tolerances); None: the default."""
    if not text:
        name = next(iter(IMPLEMENTATIONS))
        return name, IMPLEMENTATIONS[name]
    if text in IMPLEMENTATIONS:
        return text, IMPLEMENTATIONS[text]
    return 'custom', Implementation(text)

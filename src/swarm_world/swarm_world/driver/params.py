"""The driver node's options (section ``driver``): where the robots and the tracker are, and
how the driver converts and judges what they say. Not part of the model: an announcement
never carries them. docs/driver.md lists them with their meaning.
"""

from __future__ import annotations

import dataclasses

from mona_controller.schema import ParameterError, param, validate
from swarm_world.driver.calibration import DEFAULT_POINTS, CalibrationError, IrCalibration

#: How a link URL for a UDP robot starts; anything else is a serial port or pyserial URL.
UDP_PREFIX = 'udp:'


@dataclasses.dataclass(frozen=True)
class DriverParams:
    """Options of the driver node."""

    links: str = param(
        '', doc="comma-separated, robot i's link at index i: 'udp:HOST:PORT' (the "
                "robot's or its Wi-Fi bridge's address) or a serial port ('/dev/ttyUSB0', "
                'any pyserial URL); robots that share a radio name the same port, frames '
                'are told apart by robot id')
    baud: int = param(57600, unit='bit/s', low=300, high=1_000_000,
                      doc="serial links' baud rate (the firmware's, docs/link.md)")
    tracker_topic: str = param('/tracker/poses',
                               doc='the tracker: geometry_msgs/PoseArray, frame world, robot '
                                   'i at index i, NaN position = not seen')
    full_speed: float = param(0.24, unit='m/s', low=0.01, high=10.0,
                              doc="a wheel's speed at full command (1000 per-mille, PWM 255; "
                                  'MonaMk2 measured about 0.23-0.25)')
    silent_after: float = param(0.5, unit='s (wall)', low=0.01, high=3600.0,
                                doc='a robot without fresh telemetry for this long is held '
                                    'still and absent')
    tracker_timeout: float = param(0.5, unit='s (wall)', low=0.01, high=3600.0,
                                   doc='a robot the tracker has not seen for this long is held '
                                       'still and absent')
    ir_calibration: tuple[float, ...] = param(
        DEFAULT_POINTS, low=0.0, high=1023.0,
        doc='[range m, raw ADC, ...] both increasing; at or above the last ADC nothing is in '
            'range (an unmeasured guess: calibrate per robot)')
    robot_margin: float = param(0.02, unit='m', low=0.0, high=1.0,
                                doc='a beam sees a robot if the point it reports is within '
                                    "this of another tracked robot's body (tracker error)")
    battery_low: int = param(3400, unit='mV', low=0, high=20000,
                             doc='a battery below this is counted and logged (the robot goes '
                                 'on, slower; an unmeasured threshold for one Li-ion cell)')
    poll_period: float = param(0.005, unit='s (wall)', low=0.001, high=1.0,
                               doc='how often the links are read')

    def __post_init__(self) -> None:
        validate(self, 'driver.')
        try:
            IrCalibration(self.ir_calibration)
        except CalibrationError as error:
            raise ParameterError(f'driver.ir_calibration: {error}') from None
        for url in self.link_urls():
            if url.startswith(UDP_PREFIX):
                udp_address(url)

    def link_urls(self) -> list[str]:
        """The links, robot i's at index i."""
        return [url.strip() for url in self.links.split(',') if url.strip()]

    def calibration(self) -> IrCalibration:
        """The IR calibration table."""
        return IrCalibration(self.ir_calibration)


def udp_address(url: str) -> tuple[str, int]:
    """(host, port) of a ``udp:HOST:PORT`` link (ParameterError naming the URL if bad)."""
    host, _, port = url[len(UDP_PREFIX):].rpartition(':')
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ParameterError(f"driver.links: {url!r} is not 'udp:HOST:PORT'")
    return host, int(port)

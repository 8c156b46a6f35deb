"""The Mona robot: body, wheels and sensors, shared by the controller and the simulated world.

Frames follow REP 103: x forward, y left, angles counter-clockwise in radians.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar, Protocol

import numpy as np

from mona_controller.schema import ParameterError, param, validate

#: The simulator's model of the sensors and wheels: keys that left this section for the world's
#: ``sensing`` section (swarm_world.sensing.params). ``mona.<key>`` still works for one
#: release, with a DeprecatedKeyWarning naming ``sensing.<key>``.
SENSOR_MODEL = ('ground_baseline', 'ground_offset', 'ground_transfer', 'ground_height',
                'ground_lut', 'ground_reflection', 'ground_roughness', 'ground_calibration',
                'ground_table', 'ground_footprint', 'ground_noise', 'ir_miss', 'wheel_noise',
                'ir_robot_factor', 'robot_detection', 'wall_margin', 'command_latency')

#: One wheel command unit in m/s: beta = 6 drives at 8.0 cm/s (the paper; docs/model.md,
#: Controller).
WHEEL_UNIT_SPEED = 0.04 / 3.0


@dataclasses.dataclass(frozen=True)
class MonaParams:
    """A Mona as its controller knows it: body, wheels and the IR ring (the paper gives the
    body; the rest is our choice). How the simulator makes its readings is the world's
    ``sensing`` section (swarm_world.sensing.params)."""

    #: Keys that left this section, each with its new key (read here for one release).
    MOVED: ClassVar[dict[str, str]] = {key: f'sensing.{key}' for key in SENSOR_MODEL}

    body_radius: float = param(0.04, unit='m', low=0.01, high=0.5,
                               doc='radius of the disc-shaped body (8 cm diameter)')
    wheel_separation: float = param(0.07, unit='m', low=0.01, high=1.0,
                                    doc='distance between the wheels; the ground sensors sit '
                                        'under them')
    wheel_unit_speed: float = param(WHEEL_UNIT_SPEED, unit='m/s', low=1e-4, high=1.0,
                                    doc='wheel speed of one command unit (beta = 6 is 8 cm/s)')
    max_wheel_command: float = param(10.0, unit='wheel units', low=0.1, high=100.0,
                                     doc='the largest wheel command (eq. 2 clamps to [0, this])')
    ir_count: int = param(5, unit='sensors', low=1, high=16,
                          doc='front IR proximity sensors, spread evenly over ir_span')
    ir_span: float = param(2.4434609527920612, unit='rad', low=0.0, high=6.283185307179586,
                           doc='angle between the outermost IR sensors (140 deg)')
    ir_range: float = param(0.03, unit='m', low=0.001, high=0.5,
                            doc='IR detection range, measured from the body edge')

    def __post_init__(self) -> None:
        validate(self, 'mona.')
        if self.wheel_separation > 2 * self.body_radius:
            raise ParameterError(
                f'mona.wheel_separation = {self.wheel_separation} must not exceed the body '
                f'diameter 2 * mona.body_radius = {2 * self.body_radius}')

    def ir_bearings(self) -> np.ndarray:
        """Bearings of the IR sensors in the body frame (rad, right to left)."""
        if self.ir_count == 1:
            return np.zeros(1)
        return np.linspace(-self.ir_span / 2, self.ir_span / 2, self.ir_count)


class WheelGeometry(Protocol):
    """What :func:`wheels_to_twist` reads: a Mona's (or each robot's) wheel geometry."""

    @property
    def wheel_unit_speed(self) -> float | np.ndarray:
        """m/s per wheel command unit."""

    @property
    def wheel_separation(self) -> float | np.ndarray:
        """m between the wheels."""


def wheels_to_twist(wheels: np.ndarray,
                    mona: MonaParams | WheelGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Convert wheel commands [N, 2] (left, right; wheel units) to (linear m/s, angular rad/s).

    Both runners pass commands through this one function, so a command carried by a
    geometry_msgs/Twist arrives bit-identical to the embedded runner's.
    """
    left = wheels[:, 0] * mona.wheel_unit_speed
    right = wheels[:, 1] * mona.wheel_unit_speed
    return (left + right) / 2.0, (right - left) / mona.wheel_separation

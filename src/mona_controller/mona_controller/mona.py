"""The Mona robot: body, wheels and sensors, shared by the controller and the simulated world.

Frames follow REP 103: x forward, y left, angles counter-clockwise in radians.
"""

from __future__ import annotations

import dataclasses
from typing import Protocol

import numpy as np

from mona_controller.schema import ParameterError, param, validate

#: What a ground sensor reads on a cue value (swarm_world.sensing.transfer).
GROUND_TRANSFERS = ('linear', 'webots', 'table')
#: How a robot tells a robot from a wall (swarm_world.world.World.perceive).
ROBOT_DETECTIONS = ('beam', 'position')

#: One wheel command unit in m/s: beta = 6 drives at 8.0 cm/s (the paper; docs/model.md,
#: Controller).
WHEEL_UNIT_SPEED = 0.04 / 3.0


@dataclasses.dataclass(frozen=True)
class MonaParams:
    """Geometry and sensors of a Mona (the paper gives the body; the rest is our choice)."""

    body_radius: float = param(0.04, unit='m', low=0.01, high=0.5,
                               doc='radius of the disc-shaped body (8 cm diameter)')
    wheel_separation: float = param(0.07, unit='m', low=0.01, high=1.0,
                                    doc='distance between the wheels; the ground sensors sit '
                                        'under them')
    wheel_unit_speed: float = param(WHEEL_UNIT_SPEED, unit='m/s', low=1e-4, high=1.0,
                                    doc='wheel speed of one command unit (beta = 6 is 8 cm/s)')
    max_wheel_command: float = param(10.0, unit='wheel units', low=0.1, high=100.0,
                                     doc='the largest wheel command (eq. 2 clamps to [0, this])')
    ground_baseline: float = param(0.0, unit='m', low=0.0, high=1.0,
                                   doc='distance between the two ground sensors, left and right '
                                       'of the heading (0: under the wheels, '
                                       'wheel_separation apart)')
    ground_offset: float = param(0.0, unit='m', low=-0.5, high=0.5,
                                 doc='how far ahead of the wheel axle the ground sensors sit')
    ground_transfer: str = param('linear', choices=GROUND_TRANSFERS,
                                 doc="what a ground sensor reads on a cue value: 'linear' the "
                                     "value itself; 'webots' a Webots infra-red sensor over "
                                     'the printed cue, calibrated (ground_height, ground_lut, '
                                     "ground_reflection, ground_roughness, "
                                     "ground_calibration); 'table' the points of ground_table")
    ground_height: float = param(0.0099, unit='m', low=1e-4, high=0.5,
                                 doc="'webots': the sensor's height above the floor (9.9 mm in "
                                     "the first author's Webots e-puck world)")
    ground_lut: tuple[float, ...] = param((0.0, 0.0, 0.1, 1000.0), low=0.0, high=1e6,
                                          doc="'webots': the sensor's lookupTable, "
                                              '[distance m, raw value, ...], distances '
                                              "increasing (Webots' default: 1000 at 10 cm)")
    ground_reflection: float = param(0.2, low=0.0, high=1.0,
                                     doc="'webots': the share of the hit distance a black floor "
                                         'keeps: a red level r reads at distance h / (b + '
                                         "(1 - b) r) (Webots' infra-red rule, b = 0.2)")
    ground_roughness: float = param(0.0, low=0.0, high=1.0,
                                    doc="'webots': a PBR floor's roughness, which halves the "
                                        'red term at 1 (0: a plain Appearance)')
    ground_calibration: tuple[float, ...] = param((520.0, 90.0), low=-1e6, high=1e6,
                                                  doc="'webots': the raw values calibrated to "
                                                      '0 and 255, [black, white] ((520 - raw) '
                                                      "* 255 / 430 in the first author's "
                                                      'Webots world)')
    ground_table: tuple[float, ...] = param((0.0, 0.0, 255.0, 255.0), low=-1e6, high=1e6,
                                            doc="'table': [cue, reading, ...] points, cue "
                                                'increasing; linear between them, the end '
                                                'readings beyond')
    ground_footprint: float = param(0.0, unit='m', low=0.0, high=0.1,
                                    doc='side of the square floor area each ground sensor '
                                        'averages (0: the one cue cell under it)')
    ground_noise: float = param(0.0, unit='cue units', low=0.0, high=255.0,
                                doc='standard deviation of the Gaussian noise on each ground '
                                    'reading, added before rounding to 0..255')
    ir_miss: float = param(0.0, low=0.0, high=1.0,
                           doc='probability that an IR beam seeing something reports nothing '
                               '(a false negative), per beam and step')
    wheel_noise: float = param(0.0, low=0.0, high=1.0,
                               doc='relative standard deviation of each wheel speed per step '
                                   '(slip; 0.1: the wheel runs at 1 +- 0.1 of its command)')
    ir_count: int = param(5, unit='sensors', low=1, high=16,
                          doc='front IR proximity sensors, spread evenly over ir_span')
    ir_span: float = param(2.4434609527920612, unit='rad', low=0.0, high=6.283185307179586,
                           doc='angle between the outermost IR sensors (140 deg)')
    ir_range: float = param(0.03, unit='m', low=0.001, high=0.5,
                            doc='IR detection range, measured from the body edge')
    ir_robot_factor: float = param(1.0, low=0.01, high=1.0,
                                   doc='a robot body is seen within ir_range x this (a dark '
                                       "body reflects less: Webots' infra-red factor 0.2 + "
                                       '0.8 red gives 0.2 for a black one); a beam it stops '
                                       'farther away sees nothing')
    robot_detection: str = param('beam', choices=ROBOT_DETECTIONS,
                                 doc="how a robot tells a robot from a wall: 'beam' by what "
                                     "the beam hit; 'position' anything its beams see is a "
                                     'wall when its centre is within wall_margin of a wall '
                                     'or an obstacle, else a robot')
    wall_margin: float = param(0.05, unit='m', low=0.0, high=1.0,
                               doc="'position': how close to a wall or an obstacle (from the "
                                   'centre) a robot takes what it sees for a wall')
    command_latency: int = param(0, unit='control steps', low=0, high=1000,
                                 doc="how many control steps a controller's command takes to "
                                     'reach the wheels and the cleaner (a radio link: its '
                                     'latency / the control period); the answer to the '
                                     'readings of control step c drives control step c + '
                                     'this, and before the first the robot stands still, '
                                     'its cleaner off (0: at once)')

    def __post_init__(self) -> None:
        validate(self, 'mona.')
        for name in ('ground_lut', 'ground_table'):
            points = getattr(self, name)
            inputs = points[0::2]
            if len(points) < 4 or len(points) % 2 or any(
                    b <= a for a, b in zip(inputs, inputs[1:])):
                raise ParameterError(f'mona.{name} = {list(points)}: expected pairs [x, y, x, y, '
                                     '...], at least two, x increasing')
        if len(self.ground_calibration) != 2 or \
                self.ground_calibration[0] == self.ground_calibration[1]:
            raise ParameterError(f'mona.ground_calibration = {list(self.ground_calibration)}: '
                                 'expected two different raw values [black, white]')
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

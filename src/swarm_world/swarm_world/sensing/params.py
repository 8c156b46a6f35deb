"""The simulator's model of a Mona's sensors and wheels: the ``sensing`` section.

What a real Mona's controller knows of its robot (body, wheels, the IR ring's count, span and
range) is ``mona`` (:class:`mona_controller.mona.MonaParams`); how the simulator makes the
readings and moves the wheels is this section, read only by the world: where the ground
sensors sit and what they read on the printed cue (:mod:`.transfer`), the noise on the ground
readings, the IR beams and the wheels (:mod:`.noise`), how a robot is seen and told from a
wall (:meth:`swarm_world.world.World.perceive`), and the command latency (:mod:`.delay`).
These keys were ``mona.<key>`` before: a parameter file that still says so works for one
release, with a :class:`~mona_controller.schema.DeprecatedKeyWarning` naming the new key
(:data:`mona_controller.mona.SENSOR_MODEL`).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

from mona_controller.mona import SENSOR_MODEL
from mona_controller.schema import ParameterError, param, validate

#: What a ground sensor reads on a cue value (:mod:`swarm_world.sensing.transfer`).
GROUND_TRANSFERS = ('linear', 'webots', 'table')
#: How a robot tells a robot from a wall (:meth:`swarm_world.world.World.perceive`).
ROBOT_DETECTIONS = ('beam', 'position')


@dataclasses.dataclass(frozen=True)
class SensingParams:
    """How the simulator makes a Mona's readings and moves its wheels (off by default: the
    paper's model; docs/model.md)."""

    #: Where each key of this section was before (``mona.<key>``): read there for one release.
    FORMERLY: ClassVar[dict[str, str]] = {key: f'mona.{key}' for key in SENSOR_MODEL}

    ground_baseline: float = param(0.0, unit='m', low=0.0, high=1.0,
                                   doc='distance between the two ground sensors, left and right '
                                       'of the heading (0: under the wheels, '
                                       'mona.wheel_separation apart)')
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
    ir_robot_factor: float = param(1.0, low=0.01, high=1.0,
                                   doc='a robot body is seen within mona.ir_range x this (a dark '
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
        validate(self, 'sensing.')
        for name in ('ground_lut', 'ground_table'):
            points = getattr(self, name)
            inputs = points[0::2]
            if len(points) < 4 or len(points) % 2 or any(
                    b <= a for a, b in zip(inputs, inputs[1:])):
                raise ParameterError(f'sensing.{name} = {list(points)}: expected pairs [x, y, '
                                     'x, y, ...], at least two, x increasing')
        if len(self.ground_calibration) != 2 or \
                self.ground_calibration[0] == self.ground_calibration[1]:
            raise ParameterError(f'sensing.ground_calibration = {list(self.ground_calibration)}: '
                                 'expected two different raw values [black, white]')

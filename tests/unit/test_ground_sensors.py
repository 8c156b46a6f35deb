"""The ground sensors' links: what a sensor reads on a cue value (the transfer: linear, the
Webots infra-red law, a user table) and where the two sensors sit (baseline, offset)."""

import math

import numpy as np
import pytest

from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig, load_config, write_ros_yaml
from swarm_world.sensing.ground import ground_readings
from swarm_world.sensing.params import SensingParams
from swarm_world.sensing.transfer import transfer_table, webots_reading


def read(sensing: SensingParams, value: float) -> int:
    """The reading of a sensor over a uniform cue of ``value``."""
    cue = np.full((10, 10), value, dtype=np.float32)
    return int(ground_readings(cue, 0.01, np.array([[0.05, 0.05, 0.3]]), MonaParams(),
                               sensing)[0, 0])


def readings(cue: np.ndarray, poses: np.ndarray, sensing: SensingParams) -> np.ndarray:
    """Both sensors' readings of robots at ``poses`` on a 1 cm ``cue``."""
    return ground_readings(cue, 0.01, poses, MonaParams(), sensing)


def test_linear_reads_the_cue_itself():
    sensing = SensingParams()
    assert transfer_table(sensing).size == 0
    assert [read(sensing, v) for v in (0.0, 3.4, 127.5, 254.6, 255.0)] == [0, 3, 128, 255, 255]


def test_webots_law_at_the_clean_floor_the_rim_and_the_source():
    # Webots' infra-red rule with the first author's numbers (docs/model.md): a 9.9 mm high
    # sensor, the default lookup table (raw = 10000 x distance), (520 - raw) * 255 / 430.
    sensing = SensingParams(ground_transfer='webots')
    raw = lambda red: 10000 * 0.0099 / (0.2 + 0.8 * red)  # noqa: E731
    calibrated = lambda red: (520 - raw(red)) * 255 / 430  # noqa: E731
    assert webots_reading(np.array([0.0, 127.5, 255.0]), sensing) == pytest.approx(
        [calibrated(0.0), calibrated(0.5), calibrated(1.0)])
    assert [read(sensing, v) for v in (0.0, 127.5, 255.0)] == [
        round(calibrated(0.0)), round(calibrated(0.5)), round(calibrated(1.0))] == [15, 211, 250]
    # A hyperbola: steep at the rim, flat at the source (derivative d reading / d cue).
    cue = np.linspace(0.0, 255.0, 2041)
    slope = np.gradient(webots_reading(cue, sensing), cue)
    assert slope[0] == pytest.approx(4.59, abs=0.02) and slope[-1] == pytest.approx(0.184,
                                                                                   abs=0.002)
    # Roughness halves the red term: the source reads less.
    assert read(SensingParams(ground_transfer='webots', ground_roughness=1.0), 255.0) < 250


def test_readings_are_clamped_to_a_byte():
    # A calibration whose black lies above the floor's raw value reads below 0 there, and one
    # whose white lies below the source's reads above 255: both clip.
    dark = SensingParams(ground_transfer='webots', ground_calibration=(480.0, 90.0))
    assert webots_reading(np.array([0.0]), dark)[0] < 0 and read(dark, 0.0) == 0
    bright = SensingParams(ground_transfer='webots', ground_calibration=(520.0, 120.0))
    assert webots_reading(np.array([255.0]), bright)[0] > 255 and read(bright, 255.0) == 255


def test_a_user_table_reads_between_its_points_and_round_trips(tmp_path):
    sensing = SensingParams(ground_transfer='table',
                            ground_table=(0.0, 10.0, 100.0, 200.0, 255.0, 250.0))
    assert [read(sensing, v) for v in (0.0, 50.0, 100.0, 177.5, 255.0)] == [10, 105, 200, 225, 250]
    config = SwarmConfig().replace(sensing={'ground_transfer': 'table',
                                            'ground_table': list(sensing.ground_table)})
    write_ros_yaml(config, tmp_path / 'table.yaml')
    assert load_config(tmp_path / 'table.yaml').sensing == config.sensing == sensing


@pytest.mark.parametrize('key, value, message', [
    ('ground_table', [0.0, 1.0, 0.0, 2.0], 'x increasing'),
    ('ground_lut', [0.0, 0.0, 0.1], 'expected pairs'),
    ('ground_calibration', [90.0, 90.0], 'two different raw values'),
    ('ground_transfer', 'log', "sensing.ground_transfer = 'log' is not allowed"),
])
def test_a_bad_transfer_is_refused_naming_the_key(key, value, message):
    with pytest.raises(ParameterError, match=message):
        SwarmConfig().replace(sensing={key: value})


def hot_cell(x: float, y: float) -> np.ndarray:
    """A 2 m raster of 1 cm cells, 0 but for 200 in the cell holding (x, y)."""
    cue = np.zeros((200, 200), dtype=np.float32)
    cue[math.floor(y / 0.01), math.floor(x / 0.01)] = 200.0
    return cue


def test_the_sensors_sit_left_and_right_of_the_heading_ahead_of_the_axle():
    pose = np.array([[1.0, 1.0, math.pi / 2]])  # facing +y: the robot's left is -x
    under = SensingParams()  # under the wheels, 7 cm apart, on the axle
    assert readings(hot_cell(1.0 - 0.035, 1.0), pose, under)[0].tolist() == [200, 0]
    assert readings(hot_cell(1.0 + 0.035, 1.0), pose, under)[0].tolist() == [0, 200]
    ahead = SensingParams(ground_baseline=0.06, ground_offset=0.03)  # 6 cm apart, 3 cm ahead
    assert readings(hot_cell(1.0 - 0.03, 1.03), pose, ahead)[0].tolist() == [200, 0]
    assert readings(hot_cell(1.0 + 0.03, 1.03), pose, ahead)[0].tolist() == [0, 200]
    assert readings(hot_cell(1.0 - 0.035, 1.0), pose, ahead)[0].tolist() == [0, 0]


def test_a_pivoting_robot_moves_its_sensors_only_when_they_sit_ahead_of_the_axle():
    cue = np.random.default_rng(5).uniform(0, 255, (200, 200)).astype(np.float32)
    headings = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)
    turned = np.array([[1.0, 1.0, h] for h in headings])
    back = turned.copy()
    back[:, 2] += math.pi  # the same spot, turned half round
    under, ahead = SensingParams(), SensingParams(ground_offset=0.03)
    # Under the wheels a half turn swaps the two sensors' cells: the same two readings.
    first, second = (readings(cue, p, under) for p in (turned, back))
    assert np.array_equal(first, second[:, ::-1])
    # Ahead of the axle they sweep a circle: other cells.
    first, second = (readings(cue, p, ahead) for p in (turned, back))
    assert not np.array_equal(first, second[:, ::-1])

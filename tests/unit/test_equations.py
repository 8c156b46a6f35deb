"""The paper's equations: eq. 1 (waiting time), eq. 2 (gradient following), eq. 3 (cleaning)."""

import math

import numpy as np
import pytest

from mona_controller.controllers.beeclust import BeeclustParams, gradient_wheels, waiting_time
from mona_controller.controllers.params import ControllerParams
from mona_controller.controllers.reference import Longhand
from mona_controller.mona import MonaParams, wheels_to_twist
from swarm_world.cue import clean, cleaning_kernel


def test_eq1_waiting_time_uses_s_squared():
    params = BeeclustParams()
    assert waiting_time(255.0, params) == pytest.approx(21.67, abs=0.005)
    assert waiting_time(0.0, params) == 0.0
    # S^2 = 25000 gives half of w_max: the S^2 reading of the erratum, not the printed S.
    assert waiting_time(math.sqrt(25000.0), params) == pytest.approx(15.0)


def test_eq2_straight_on_equal_readings_and_clamped():
    wheels = gradient_wheels(np.array([[100, 100], [0, 255], [255, 0]], dtype=np.uint8),
                             beta=6.0, alpha=2.0, max_command=10.0)
    assert wheels[0].tolist() == [6.0, 6.0]
    # s_l - s_r = -255: N_r = -127.5 + 6 -> 0, N_l = 127.5 + 6 -> 10.
    assert wheels[1].tolist() == [10.0, 0.0]
    assert wheels[2].tolist() == [0.0, 10.0]


def test_eq2_turns_toward_the_stronger_sensor():
    mona = MonaParams()
    stronger_left = np.array([[120, 110]], dtype=np.uint8)
    stronger_right = np.array([[110, 120]], dtype=np.uint8)
    _, turn_left = wheels_to_twist(gradient_wheels(stronger_left, 6.0, 2.0, 10.0), mona)
    _, turn_right = wheels_to_twist(gradient_wheels(stronger_right, 6.0, 2.0, 10.0), mona)
    assert turn_left[0] > 0  # counter-clockwise (REP 103): toward the left sensor
    assert turn_right[0] < 0


def test_eq2_speed_units():
    mona = MonaParams()
    linear, angular = wheels_to_twist(np.array([[6.0, 6.0], [3.0, 3.0]]), mona)
    assert linear == pytest.approx([0.08, 0.04])
    assert angular == pytest.approx([0.0, 0.0])


def test_the_reference_writes_eq1_and_eq2_out_to_the_bit():
    # Longhand's plain-Python formulas against the vectorised ones (which fill the
    # controller's tables), for every pair of ground bytes.
    own = BeeclustParams(wait_max=17.0, alpha=1.5)
    params, mona = ControllerParams.of(own, speed=0.1), MonaParams()
    hand = Longhand(params, mona, robot_id=0, seed=0)
    pairs = [(left, right) for left in range(256) for right in range(256)]
    ground = np.array(pairs, dtype=np.uint8)
    assert np.array([hand.wait(*pair) for pair in pairs]).tobytes() == waiting_time(
        ground.astype(np.float64).mean(axis=1), own).tobytes()
    assert np.array([hand.follow(*pair) for pair in pairs]).tobytes() == gradient_wheels(
        ground, hand.beta, own.alpha, mona.max_wheel_command).tobytes()


def test_eq3_kernel_centre_and_corners():
    kernel = cleaning_kernel(4, 8.0)
    assert kernel.shape == (9, 9)
    assert kernel[4, 4] == pytest.approx(8.0)
    for corner in (kernel[0, 0], kernel[0, 8], kernel[8, 0], kernel[8, 8]):
        assert corner == pytest.approx(8.0 - math.sqrt(32.0), abs=1e-5)  # 2.34
    assert kernel[4, 0] == pytest.approx(4.0)


def test_eq3_monotone_never_below_zero_nor_above_before():
    cue = np.full((20, 20), 5.0, dtype=np.float32)
    cue[10, 10] = 100.0
    before = cue.copy()
    clean(cue, np.array([[10, 10]]), cleaning_kernel(4, 8.0))
    assert cue.min() >= 0.0
    assert np.all(cue <= before)
    assert cue[10, 10] == pytest.approx(92.0)
    assert cue[10, 12] == 0.0  # 5 - 6 floors at 0
    assert cue[0, 0] == 5.0  # outside the patch


def test_eq3_patch_clipped_at_the_arena_edge():
    cue = np.full((10, 10), 50.0, dtype=np.float32)
    clean(cue, np.array([[0, 0]]), cleaning_kernel(4, 8.0))
    assert cue[0, 0] == pytest.approx(42.0)
    assert cue[4, 4] == pytest.approx(50.0 - (8.0 - math.sqrt(32.0)), abs=1e-5)
    assert cue[5, 5] == 50.0


def test_eq3_literal_form_can_raise_cleaner_cells():
    cue = np.zeros((20, 20), dtype=np.float32)
    cue[10, 10] = 200.0
    clean(cue, np.array([[10, 10]]), cleaning_kernel(4, 8.0),
          literal_levels=np.array([100.0]))
    assert cue[10, 10] == pytest.approx(92.0)  # 100 - 8, not 200 - 8
    assert cue[10, 11] == pytest.approx(93.0)  # was 0: the literal form adds contamination

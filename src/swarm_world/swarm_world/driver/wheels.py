"""Wheel speeds between a controller's twist, the link's wheel command and the PWM.

A controller answers with ``cmd_vel`` (``linear = (l + r) / 2``, ``angular = (r - l) /
wheel_separation``, docs/interfaces.md): the driver recovers the wheel speeds (m/s) and sends
them as per-mille of the wheel's full speed (docs/link.md, "Payloads"); the firmware maps
per-mille to PWM through its deadband. The emulator reads the PWM back to a speed.
"""

from __future__ import annotations

import math

from mona_controller.link.payloads import FULL_SPEED

#: The firmware's default deadband (docs/link.md, "Timings"): PWM of the smallest command.
DEADBAND = 25
PWM_MAX = 255


def twist_to_wheels(linear: float, angular: float, wheel_separation: float) -> tuple[float,
                                                                                       float]:
    """(left, right) wheel speeds (m/s) of a twist: the inverse of ``wheels_to_twist``."""
    half = angular * wheel_separation / 2.0
    return linear - half, linear + half


def to_permille(speed: float, full_speed: float) -> int:
    """A wheel speed (m/s) as the link's command: per-mille of ``full_speed``, rounded,
    clamped to +-1000; a non-finite speed is a stop."""
    if not math.isfinite(speed):
        return 0
    return max(-FULL_SPEED, min(FULL_SPEED, round(speed / full_speed * FULL_SPEED)))


def pwm_to_permille(pwm: int, reverse: bool, deadband: int = DEADBAND) -> float:
    """The command (per-mille, signed) that the firmware's deadband map turns into ``pwm``
    (``pwm = deadband + round(|v| x (255 - deadband) / 1000)``), as a real number: PWM 0 is
    a stop, PWM at or below the deadband the smallest motion."""
    if pwm <= 0:
        return 0.0
    magnitude = max(pwm - deadband, 0) * FULL_SPEED / (PWM_MAX - deadband)
    return -magnitude if reverse else magnitude

"""The IR calibration: a raw 10-bit ADC reading of a Mona's IR sensor to a range, and back.

The firmware reports each IR sensor as the raw ADC value (docs/link.md, "Telemetry"): 1023
is nothing seen, lower is closer. The driver maps it to the distance from the body edge that
``proximity`` carries (docs/interfaces.md) through a table of measured points, linear
between them; a reading at or above the table's last ADC value is nothing in range (inf).
The shipped table is a guess of the sensor's shape, **not measured** on a Mona: calibrate
it per robot (docs/driver.md, "Calibration").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: The largest 10-bit ADC value: the pin at AVcc, nothing reflects.
ADC_MAX = 1023
#: (range m, ADC) points, range increasing and ADC increasing: contact reads 200, the end of
#: the 3 cm range 1000 (an unmeasured guess; docs/driver.md).
DEFAULT_POINTS = (0.0, 200.0, 0.01, 560.0, 0.02, 850.0, 0.03, 1000.0)


class CalibrationError(ValueError):
    """A calibration table that cannot map readings both ways."""


@dataclass(frozen=True)
class IrCalibration:
    """Pairs ``[range m, adc, range m, adc, ...]``, both increasing (a farther obstacle
    reflects less and reads higher)."""

    points: tuple[float, ...] = DEFAULT_POINTS

    def __post_init__(self) -> None:
        points = self.points
        if len(points) < 4 or len(points) % 2:
            raise CalibrationError(f'IR calibration {list(points)}: expected pairs [range, '
                                   'adc, ...], at least two')
        ranges, adcs = np.array(points[0::2]), np.array(points[1::2])
        if np.any(np.diff(ranges) <= 0) or np.any(np.diff(adcs) <= 0):
            raise CalibrationError(f'IR calibration {list(points)}: ranges and ADC values '
                                   'must both increase')
        if ranges[0] < 0 or adcs[0] < 0 or adcs[-1] > ADC_MAX:
            raise CalibrationError(f'IR calibration {list(points)}: ranges from 0 m, ADC '
                                   f'values within 0..{ADC_MAX}')

    @property
    def ranges(self) -> np.ndarray:
        """The table's ranges (m)."""
        return np.array(self.points[0::2], dtype=np.float64)

    @property
    def adcs(self) -> np.ndarray:
        """The table's ADC values."""
        return np.array(self.points[1::2], dtype=np.float64)

    @property
    def far(self) -> float:
        """The ADC value from which nothing is in range."""
        return float(self.points[-1])

    def to_ranges(self, raw: Sequence[int] | np.ndarray) -> np.ndarray:
        """Ranges (m, float32; inf = nothing in range) of raw ADC readings."""
        raw = np.asarray(raw, dtype=np.float64)
        ranges: np.ndarray = np.interp(raw, self.adcs, self.ranges).astype(np.float32)
        ranges[raw >= self.far] = np.inf
        return ranges

    def to_adc(self, ranges: Sequence[float] | np.ndarray) -> np.ndarray:
        """What the sensor reads (int ADC) at ``ranges`` (m; inf or beyond the table:
        :data:`ADC_MAX`): the inverse of :meth:`to_ranges`, for an emulated robot."""
        ranges = np.asarray(ranges, dtype=np.float64)
        beyond = ~np.isfinite(ranges) | (ranges >= self.ranges[-1])
        clipped = np.where(beyond, self.ranges[-1], np.maximum(ranges, 0.0))
        adc: np.ndarray = np.rint(np.interp(clipped, self.ranges, self.adcs)).astype(np.int64)
        adc = np.minimum(adc, round(self.far) - 1)  # in range reads below the far value
        adc[beyond] = ADC_MAX
        return adc

    def millivolts(self, adc: np.ndarray, avcc_mv: int = 3300) -> np.ndarray:
        """The pin voltage (mV) an emulator applies for ``adc`` (simavr's ADC gives
        ``mV x 1023 / AVcc``, docs/link.md): rounded up, so the conversion floors back."""
        return np.ceil(np.asarray(adc, dtype=np.float64) * avcc_mv / ADC_MAX).astype(np.int64)

"""What a ground sensor reads on a cue cell: the transfer from the printed cue to a reading.

``linear`` (the default, the paper's model as we first read it): the reading is the cue
itself. ``webots``: the reading of an infra-red DistanceSensor pointing at the floor in
Webots, calibrated to 0..255, as docs/model.md ("The ground sensors of a Webots robot")
derives it from Webots' own code: the floor's red channel r = cue / 255 scales the hit
distance h to h / f with f = b + (1 - b) r (1 - roughness / 2) (b = 0.2: a black floor
reflects a fifth), the lookup table maps that distance to a raw value, and a two-point
calibration maps the raw values on black and on white to 0 and 255. A hyperbola: at the rim
the reading climbs about five times faster than the cue, at the source about a fifth as
fast, and the clean floor reads above 0. ``table``: a user's table of (cue, reading) points.

A transfer is worked out once per parameter set as a table of :data:`KNOTS` readings at evenly
spaced cue values; the ground kernel interpolates it (the readings are rounded to whole
numbers afterwards, so the table's resolution of a quarter of a cue unit is exact enough).
"""

from __future__ import annotations

import functools

import numpy as np

from swarm_world.sensing.params import SensingParams

#: Readings tabulated at cue 0, 255 / (KNOTS - 1), ..., 255.
KNOTS = 1021


def lookup(table: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """A Webots lookup table ([input, output, input, output, ...], inputs increasing) at
    ``x``: linear between its rows, its first or last output beyond them."""
    inputs, outputs = np.asarray(table[0::2]), np.asarray(table[1::2])
    read: np.ndarray = np.interp(x, inputs, outputs)
    return read


def webots_reading(cue: np.ndarray, sensing: SensingParams) -> np.ndarray:
    """The calibrated reading (not yet rounded or clipped) of a Webots infra-red ground
    sensor over cue values ``cue`` (0..255), with ``sensing``'s height, lookup table,
    reflection baseline, roughness and calibration."""
    red = np.clip(np.asarray(cue, dtype=np.float64) / 255.0, 0.0, 1.0)
    baseline = sensing.ground_reflection
    factor = baseline + (1.0 - baseline) * red * (1.0 - 0.5 * sensing.ground_roughness)
    raw = lookup(sensing.ground_lut, sensing.ground_height / factor)
    black, white = sensing.ground_calibration
    return (black - raw) * 255.0 / (black - white)


@functools.lru_cache(maxsize=64)
def transfer_table(sensing: SensingParams) -> np.ndarray:
    """The readings at :data:`KNOTS` evenly spaced cue values, float64, read-only; empty for
    the ``linear`` transfer (the kernel then reads the cue itself, as it always did)."""
    if sensing.ground_transfer == 'linear':
        table = np.zeros(0)
    else:
        cue = np.linspace(0.0, 255.0, KNOTS)
        if sensing.ground_transfer == 'webots':
            table = webots_reading(cue, sensing)
        else:  # 'table': the user's points, linear between them
            table = lookup(sensing.ground_table, cue)
    table.flags.writeable = False
    return table

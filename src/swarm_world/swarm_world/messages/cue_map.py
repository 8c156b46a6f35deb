"""The cue raster as message data: what both runners put in ``/world/cue_map`` (a mono8
image) and ``/world/cue_grid`` (an occupancy grid). Pure (no ROS)."""

from __future__ import annotations

import numpy as np


def cue_mono8(cue: np.ndarray) -> np.ndarray:
    """The cue raster as uint8, rounded as the ground sensors read it (row 0 at y = 0)."""
    mono8: np.ndarray = np.clip(np.rint(cue), 0, 255).astype(np.uint8)
    return mono8


def cue_percent(cue: np.ndarray) -> np.ndarray:
    """The cue raster scaled from 0..255 to an occupancy grid's 0..100, rounded (int8, row 0
    at y = 0)."""
    return np.clip(np.rint(cue.astype(np.float64) * (100.0 / 255.0)), 0, 100).astype(np.int8)

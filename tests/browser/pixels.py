"""What a person sees in a screenshot of the Foxglove panels, as numbers (numpy only).

The layout (ros_ws/config/foxglove_layout.json) draws each robot as a disc in its controller
state's colour with a white heading arrow, the arena's outline and grid in yellow, the
obstacles in cyan and the sources in magenta (their markers' own colour); these functions
find those colours by hue (the 3D panel shades a colour, it does not keep it exact) and
measure where they are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

#: Hue (degrees) of each controller state's colour as the 3D panel draws it
#: (BEECLUST's states, mona_controller.controllers.beeclust.STATES: green, orange, red, blue).
STATE_HUES = {'follow': 125.0, 'avoid': 37.0, 'wait': 0.0, 'turn': 224.0}
#: The arena outline (layer colour #fff000), the obstacles (#00bcd4) and the sources
#: (swarm_world.arena_markers.SOURCE_COLOUR, magenta).
OUTLINE_HUE, OBSTACLE_HUE, SOURCE_HUE = 56.5, 187.0, 300.0
HUE_TOLERANCE = 14.0


def hsv(image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hue (degrees), saturation and value (0..1) of an RGB(A) uint8 image."""
    rgb = image[..., :3].astype(np.float64) / 255.0
    high, low = rgb.max(axis=-1), rgb.min(axis=-1)
    span = high - low
    safe = np.where(span > 0, span, 1.0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hue = np.select([high == r, high == g], [((g - b) / safe) % 6, (b - r) / safe + 2],
                    (r - g) / safe + 4) * 60.0
    saturation = np.where(high > 0, span / np.where(high > 0, high, 1.0), 0.0)
    return np.where(span > 0, hue, 0.0), saturation, high


def hue_mask(image: np.ndarray, hue: float, tolerance: float = HUE_TOLERANCE,
             saturation: float = 0.55, value: float = 0.45) -> np.ndarray:
    """Pixels of a vivid colour whose hue is within ``tolerance`` degrees of ``hue``."""
    h, s, v = hsv(image)
    distance = np.abs((h - hue + 180.0) % 360.0 - 180.0)
    return (distance <= tolerance) & (s >= saturation) & (v >= value)


def white_mask(image: np.ndarray) -> np.ndarray:
    """Near-white pixels (the robots' heading arrows)."""
    _, s, v = hsv(image)
    return (s < 0.12) & (v > 0.9)


@dataclass(frozen=True)
class Box:
    """A pixel bounding box, ``x0 <= x < x1``, ``y0 <= y < y1``."""

    x0: int
    y0: int
    x1: int
    y1: int

    @property
    def centre(self) -> tuple[float, float]:
        """The box's centre (x, y) in pixels."""
        return (self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return self.x1 - self.x0, self.y1 - self.y0


def bounding_box(mask: np.ndarray) -> Box | None:
    """The box around every set pixel of ``mask``, or None when none is set."""
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        return None
    return Box(int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1)


def blobs(mask: np.ndarray, min_pixels: int = 6) -> list[tuple[float, float, int]]:
    """Connected groups of set pixels (8-neighbour): ``(x, y, pixels)`` of each, small
    specks (anti-aliasing fringes) left out."""
    labels, count = ndimage.label(mask, structure=np.ones((3, 3), dtype=bool))
    found = []
    for index in range(1, count + 1):
        ys, xs = np.nonzero(labels == index)
        if len(xs) >= min_pixels:
            found.append((float(xs.mean()), float(ys.mean()), int(len(xs))))
    return found


def robot_blobs(image: np.ndarray) -> dict[str, list[tuple[float, float, int]]]:
    """State name -> the robot discs drawn in that state's colour."""
    return {state: blobs(hue_mask(image, hue)) for state, hue in STATE_HUES.items()}


def to_pixels(points: np.ndarray, arena: Box, side: float) -> np.ndarray:
    """World (x, y) in metres -> pixel (x, y) in a top-down view whose arena (a ``side`` m
    square with its corner at the origin) is drawn as ``arena`` (y grows upwards in the
    world, downwards in the image)."""
    width, height = arena.size
    px = arena.x0 + points[:, 0] / side * width
    py = arena.y1 - points[:, 1] / side * height
    return np.stack([px, py], axis=1)


def correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two same-shaped arrays (0 when either is flat)."""
    a = a.astype(np.float64).ravel() - a.mean()
    b = b.astype(np.float64).ravel() - b.mean()
    norm = np.sqrt((a * a).sum() * (b * b).sum())
    return float((a * b).sum() / norm) if norm > 0 else 0.0


def block_mean(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A grey image reduced to ``shape`` by averaging the pixels of each block."""
    grey = image[..., :3].mean(axis=-1) if image.ndim == 3 else image.astype(np.float64)
    rows = np.linspace(0, grey.shape[0], shape[0] + 1).astype(int)
    cols = np.linspace(0, grey.shape[1], shape[1] + 1).astype(int)
    out = np.empty(shape)
    for i in range(shape[0]):
        for j in range(shape[1]):
            out[i, j] = grey[rows[i]:max(rows[i + 1], rows[i] + 1),
                             cols[j]:max(cols[j + 1], cols[j] + 1)].mean()
    return out

"""Pictures of the cue map and the swarm (matplotlib, headless)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use('Agg')  # files only; never needs a display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PatchCollection  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402
from matplotlib.patches import Polygon as MatplotlibPolygon  # noqa: E402

from swarm_world.arena import Disc, Obstacle  # noqa: E402
from swarm_world.messages.markers import COLOUR as OBSTACLE_RGBA  # noqa: E402

#: An obstacle's outline (its fill is the markers' grey, as in the videos and Foxglove).
OBSTACLE_EDGE = (0.25, 0.25, 0.25)

#: Cue raster cells drawn across a figure at most (see :func:`draw_cue_map`).
MAX_SHOWN_CELLS = 1000


def draw_cue_map(ax, cue: np.ndarray, poses: np.ndarray | None, arena_side: float,
                 body_radius: float, *, peak: float = 255.0, title: str | None = None,
                 obstacles: Sequence[Obstacle] = ()):
    """Draw the cue raster (world frame, y up) with the obstacles as filled grey shapes (as
    the videos show them) and the robots as discs with heading ticks."""
    # A figure shows a few hundred pixels across: a large arena's raster (4,000 cells across
    # for 10,000 robots) is thinned to at most MAX_SHOWN_CELLS first, which matplotlib's own
    # resampling would have done anyway, at seconds per image. Smaller rasters are untouched.
    stride = -(-max(cue.shape) // MAX_SHOWN_CELLS)
    if stride > 1:
        cue = cue[::stride, ::stride]
    image = ax.imshow(cue, origin='lower', extent=(0, arena_side, 0, arena_side),
                      cmap='viridis', vmin=0, vmax=peak, interpolation='nearest')
    if obstacles:
        shapes = [Circle((o.x, o.y), o.radius) if isinstance(o, Disc) else
                  MatplotlibPolygon(o.vertices, closed=True) for o in obstacles]
        ax.add_collection(PatchCollection(shapes, facecolor=OBSTACLE_RGBA[:3],
                                          edgecolor=OBSTACLE_EDGE, linewidth=0.8))
    if poses is not None and len(poses):
        discs = [Circle((x, y), body_radius) for x, y, _ in poses]
        ax.add_collection(PatchCollection(discs, facecolor='white', edgecolor='black',
                                          linewidth=0.4))
        tip = poses[:, :2] + body_radius * np.column_stack((np.cos(poses[:, 2]),
                                                            np.sin(poses[:, 2])))
        # One collection, not a line per robot: 10,000 Line2D artists take a minute to draw.
        ax.add_collection(LineCollection(np.stack((poses[:, :2], tip), axis=1),  # type: ignore[arg-type]
                                         colors='red', linewidths=0.6, capstyle='projecting'))
    ax.set_xlim(0, arena_side)
    ax.set_ylim(0, arena_side)
    ax.set_aspect('equal')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    if title:
        ax.set_title(title)
    return image


def save_cue_map(path: str | Path, cue: np.ndarray, poses: np.ndarray | None,
                 arena_side: float, body_radius: float, *, title: str | None = None,
                 obstacles: Sequence[Obstacle] = ()) -> None:
    """Write one cue map with the obstacles and the robots to a PNG file."""
    # A fixed layout (what tight_layout finds for this figure): laying it out costs a whole
    # extra draw, a third of the time of every episode's picture.
    fig = plt.figure(figsize=(5.5, 5))
    ax = fig.add_axes((0.13, 0.1, 0.66, 0.8))
    image = draw_cue_map(ax, cue, poses, arena_side, body_radius, title=title,
                         obstacles=obstacles)
    fig.colorbar(image, cax=fig.add_axes((0.82, 0.1, 0.035, 0.8)),
                 label='cue intensity (0..255)')
    fig.savefig(path, dpi=120)
    plt.close(fig)

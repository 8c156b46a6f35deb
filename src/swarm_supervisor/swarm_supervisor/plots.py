"""Pictures of the cue map and the swarm (matplotlib, headless)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use('Agg')  # files only; never needs a display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PatchCollection  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402


def draw_cue_map(ax, cue: np.ndarray, poses: np.ndarray | None, arena_side: float,
                 body_radius: float, *, peak: float = 255.0, title: str | None = None):
    """Draw the cue raster (world frame, y up) with the robots as discs and heading ticks."""
    image = ax.imshow(cue, origin='lower', extent=(0, arena_side, 0, arena_side),
                      cmap='viridis', vmin=0, vmax=peak, interpolation='nearest')
    if poses is not None and len(poses):
        discs = [Circle((x, y), body_radius) for x, y, _ in poses]
        ax.add_collection(PatchCollection(discs, facecolor='white', edgecolor='black',
                                          linewidth=0.4))
        tip = poses[:, :2] + body_radius * np.column_stack((np.cos(poses[:, 2]),
                                                            np.sin(poses[:, 2])))
        for (x, y, _), (tx, ty) in zip(poses, tip):
            ax.plot((x, tx), (y, ty), color='red', linewidth=0.6)
    ax.set_xlim(0, arena_side)
    ax.set_ylim(0, arena_side)
    ax.set_aspect('equal')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    if title:
        ax.set_title(title)
    return image


def save_cue_map(path: str | Path, cue: np.ndarray, poses: np.ndarray | None,
                 arena_side: float, body_radius: float, *, title: str | None = None) -> None:
    """Write one cue map with the robots to a PNG file."""
    fig, ax = plt.subplots(figsize=(5.5, 5))
    image = draw_cue_map(ax, cue, poses, arena_side, body_radius, title=title)
    fig.colorbar(image, ax=ax, label='cue intensity (0..255)')
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)

"""What a person should see in the layout, checked on a :class:`foxapp.View`.

:func:`findings` returns one sentence per thing that is not as it should be (an empty list:
all is well), so a test asserts ``findings(...) == []`` and the test of a broken layout
asserts which findings appear. Every check is positive: a topic name the data does not
carry raises no error in the app, it only leaves a panel empty, so emptiness is what fails.
"""

from __future__ import annotations

import json
import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pixels
from foxapp import View

#: The arena's side (m), ros_ws/config/mona_swarm.yaml's world.arena_size.
SIDE = 2.85


@dataclass(frozen=True)
class Expected:
    """What the source holds at the moment looked at."""

    population: int
    seed: int
    mode: str                              # the status's mode: embedded, lockstep
    plots: dict[str, tuple[str, str]]      # plot panel id -> (legend label, series colour)
    positions: np.ndarray | None = None    # robots' (x, y) shown (a bag at a seek time)
    cue: np.ndarray | None = None          # the cue map shown (a bag), uint8 rows x cols
    states: np.ndarray | None = None       # their controller states shown (a bag)
    sources: np.ndarray | None = None      # the sources' (x, y) shown (a bag)
    obstacle_area: float = 0.0             # m^2 of obstacles in the arena (drawn cyan)


def plots_of(layout: Path) -> dict[str, tuple[str, str]]:
    """The layout's plot panels: id -> (the legend label, the series colour)."""
    config = json.loads(layout.read_text())['configById']
    return {panel: (settings['paths'][0]['label'], settings['paths'][0]['color'])
            for panel, settings in config.items() if panel.startswith('Plot!')}


def rgb(colour: str) -> tuple[int, int, int]:
    """``#rrggbb`` as integers."""
    return int(colour[1:3], 16), int(colour[3:5], 16), int(colour[5:7], 16)


def series_hue(colour: str) -> float:
    """The hue (degrees) of a ``#rrggbb`` colour."""
    hue, _, _ = pixels.hsv(np.array([[rgb(colour)]], dtype=np.uint8))
    return float(hue[0, 0])


def scene_findings(scene: np.ndarray, expected: Expected) -> list[str]:
    """The 3D panel: the arena outline centred and large, the robots drawn (where they
    are, when known) in their states' colours with a heading."""
    found: list[str] = []
    if scene.size == 0:
        return ['the 3D panel draws nothing (no canvas)']
    height, width = scene.shape[:2]
    outline = pixels.bounding_box(pixels.hue_mask(scene, pixels.OUTLINE_HUE))
    if outline is None:
        return ['the 3D panel shows no arena outline']
    cx, cy = outline.centre
    bw, bh = outline.size
    if abs(cx - width / 2) > 0.04 * width or abs(cy - height / 2) > 0.04 * height:
        found.append(f'the arena is not centred in the 3D panel: its centre is at '
                     f'({cx:.0f}, {cy:.0f}) px of a {width} x {height} panel')
    if min(bw, bh) < 0.5 * min(width, height) or abs(bw - bh) > 0.05 * max(bw, bh):
        found.append(f'the arena outline is {bw} x {bh} px in a {width} x {height} panel '
                     '(not a large square)')
    robots = pixels.robot_blobs(scene)
    area = sum(size for blobs in robots.values() for _, _, size in blobs)
    # A disc of 8 cm seen on an arena drawn bw px wide, at least half visible.
    disc = np.pi * (0.04 / SIDE * bw) ** 2
    if area < 0.5 * expected.population * disc:
        found.append(f'the 3D panel shows {area} px of robot colour, less than half of '
                     f'{expected.population} robots of {disc:.0f} px')
    headings = int(pixels.white_mask(scene).sum())
    if headings < expected.population * 2:
        found.append(f'the 3D panel shows {headings} px of heading arrows for '
                     f'{expected.population} robots')
    if expected.positions is not None:
        found += position_findings(scene, outline, expected.positions, expected.states)
    found += source_findings(scene, outline, expected.sources)
    if expected.obstacle_area > 0:
        drawn = int(pixels.hue_mask(scene, pixels.OBSTACLE_HUE).sum())
        area = expected.obstacle_area * (bw / SIDE) ** 2
        if drawn < 0.5 * area:
            found.append(f'the 3D panel shows {drawn} px of obstacles, less than half of '
                         f'their {area:.0f} px')
    return found


def source_findings(scene: np.ndarray, outline: pixels.Box,
                    sources: np.ndarray | None) -> list[str]:
    """The sources' markers drawn (a bag: each where the bag puts it)."""
    mask = pixels.hue_mask(scene, pixels.SOURCE_HUE)
    if not pixels.blobs(mask):
        return ['the 3D panel shows no source marker']
    if sources is None:
        return []
    radius = max(3, int(round(0.04 / SIDE * outline.size[0])))
    missing = []
    for k, (x, y) in enumerate(pixels.to_pixels(sources, outline, SIDE)):
        if not mask[max(0, int(y) - radius):int(y) + radius + 1,
                    max(0, int(x) - radius):int(x) + radius + 1].any():
            missing.append(k)
    return [f'no source marker where sources {missing} are'] if missing else []


def position_findings(scene: np.ndarray, outline: pixels.Box, positions: np.ndarray,
                      states: np.ndarray | None) -> list[str]:
    """Each robot's disc drawn where the source says the robot is, in its state's colour
    (any state's colour when the states are not known)."""
    names = list(pixels.STATE_HUES)
    masks = [pixels.hue_mask(scene, hue) for hue in pixels.STATE_HUES.values()]
    anything = np.logical_or.reduce(masks)
    expected = pixels.to_pixels(positions, outline, SIDE)
    radius = max(3, int(round(0.04 / SIDE * outline.size[0])))
    missing, wrong = [], []
    for k, (x, y) in enumerate(expected):
        x0, x1 = max(0, int(x) - radius), int(x) + radius + 1
        y0, y1 = max(0, int(y) - radius), int(y) + radius + 1
        if not anything[y0:y1, x0:x1].any():
            missing.append(k)
        elif states is not None and not masks[int(states[k])][y0:y1, x0:x1].any():
            wrong.append((k, names[int(states[k])]))
    found = []
    # A robot hidden under another's disc is possible in a cluster: allow one in ten.
    if len(missing) > len(positions) // 10:
        found.append(f'no robot disc where robots {missing[:10]} are ({len(missing)} of '
                     f'{len(positions)} missing)')
    if len(wrong) > len(positions) // 10:
        found.append(f"robots not in their states' colours: {wrong[:10]} ({len(wrong)} of "
                     f'{len(positions)})')
    return found


def cue_findings(image: np.ndarray, cue: np.ndarray | None) -> list[str]:
    """The image panel shows the cue map: not flat, and (a bag) the very map recorded."""
    if image.size == 0:
        return ['the cue map panel draws nothing (no canvas)']
    grey = image[..., :3].mean(axis=-1)
    if grey.std() < 10:
        return [f'the cue map panel is flat (grey std {grey.std():.1f})']
    if cue is None:
        return []
    # Fit mode: the square map centred, as large as the panel's shorter side.
    height, width = grey.shape
    side = min(height, width)
    top, left = (height - side) // 2, (width - side) // 2
    shown = pixels.block_mean(grey[top:top + side, left:left + side], (57, 57))
    truth = pixels.block_mean(cue.astype(np.float64), (57, 57))
    r = pixels.correlation(shown, truth)
    if r < 0.9:
        return [f'the cue map panel does not show the recorded map (correlation {r:.2f})']
    return []


def plot_findings(plots: dict[str, tuple[str, np.ndarray]],
                  expected: Expected) -> list[str]:
    """Each metric plot draws its series (its colour's pixels) with a legend value."""
    found = []
    for panel, (label, colour) in expected.plots.items():
        if panel not in plots:
            found.append(f'no plot panel {panel}')
            continue
        text, image = plots[panel]
        number = re.search(r'-?\d+(\.\d+)?(e-?\d+)?', text.split(label[:12])[-1]
                           if label[:12] in text else '')
        if label[:12] not in text or number is None:
            found.append(f'the plot {label!r} has no legend value (its text: {text!r})')
        # By hue: a thin anti-aliased line keeps its colour's hue, not its value.
        near = pixels.hue_mask(image, series_hue(colour), tolerance=10.0, saturation=0.35,
                               value=0.25) if image.size else np.zeros((0, 0), dtype=bool)
        # A series spans the plot; the legend's swatch of the same colour covers a few columns.
        columns = float(near.any(axis=0).mean()) if near.size else 0.0
        if columns < 0.3:
            found.append(f'the plot {label!r} draws no series (its colour {colour} in '
                         f'{columns:.0%} of the columns)')
    return found


def text_findings(view: View, expected: Expected) -> list[str]:
    """The announcement and status panels show the episode; the problem list is empty."""
    found = []
    if f'"seed": {expected.seed}' not in view.episode_text or \
            f'"population": {expected.population}' not in view.episode_text:
        found.append(f'the announcement panel does not show seed {expected.seed} and '
                     f'population {expected.population}: {view.episode_text[:200]!r}')
    if f'"mode": "{expected.mode}"' not in view.status_text or '"state": "' not in \
            view.status_text:
        found.append(f'the status panel does not show a {expected.mode} status: '
                     f'{view.status_text[:200]!r}')
    if 'No problems found' not in view.problems:
        found.append(f'the app lists problems: {view.problems[:400]!r}')
    return found


def findings(view: View, expected: Expected) -> list[str]:
    """Every way the view differs from what a person should see (empty: none)."""
    return (scene_findings(view.scene, expected) + cue_findings(view.cue_map, expected.cue) +
            plot_findings(view.plots, expected) + text_findings(view, expected))


def settle(app, expected: Expected, timeout: float = 120.0,
           enough=lambda found: not found) -> tuple[View, list[str]]:
    """Look at the app until ``enough(findings)`` holds (by default: no findings) or
    ``timeout`` seconds pass (panels fill in as messages arrive); the last look and its
    findings."""
    deadline = time.monotonic() + timeout
    while True:
        started = time.monotonic()
        view = app.look(list(expected.plots))
        found = findings(view, expected)
        print(f'looked in {time.monotonic() - started:.1f} s: {len(found)} findings '
              f'{[line[:60] for line in found]}')
        if enough(found) or time.monotonic() > deadline:
            return view, found
        app.page.wait_for_timeout(2000)

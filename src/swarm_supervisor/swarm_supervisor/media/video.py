"""Videos of episodes: the cue map being cleaned, the obstacles as filled grey shapes, the
robots coloured by state, the clock and the plotted metrics growing (the paper's three, and
any registered metric with a plot label: :func:`swarm_metrics.metrics.plotted`), from any
episode bag (either runner's).

Fast by construction: matplotlib draws the static parts (axes, labels, legend) and the full
metric curves once; each frame is then composed in numpy (the cue through a colour table,
the obstacles as a mask painted over it, the robots as stamped discs, the curves revealed up
to the frame's time) and only the clock is drawn per frame (Pillow). A 4000 s episode of 50
robots at 100x (1000 frames) renders in 16-17 s on a busy 2-core machine (11 s of CPU).

The cue of a frame is rebuilt from the cleaning record (:class:`swarm_world.field.CueField`,
as the analysis does), so the map is exact at every frame, whatever the recorded cue map
period; the robots are shown at the latest recorded pose (the metric sample times); the
obstacles are the bag's ``/world/obstacles`` markers, read back into shapes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

# The object-oriented API on the Agg canvas: no pyplot, so no display backend is needed.
from matplotlib import colormaps, font_manager
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from PIL import Image, ImageDraw, ImageFont

from swarm_metrics.metrics import METRICS, plotted
from swarm_supervisor.media.recorded import AnimateError, Record, read_record
from swarm_world.field import CueField
from swarm_world.messages.markers import COLOUR as OBSTACLE_RGBA

ASPECT = 16 / 9
#: Frame widths by output kind when none is given: a still is looked at closely.
DEFAULT_WIDTH = {'.mp4': 1024, '.gif': 640, '.png': 1280}
#: The vertical pitch and height of the metric plots (figure fractions): three fill the
#: column; more share it.
PLOT_PITCH, PLOT_HEIGHT, PLOT_COLUMN = 0.27, 0.22, 0.81
MOVING_COLOUR = (0.85, 0.85, 0.85, 1.0)  # robots of a bag without states, not cleaning
CLEANING_COLOUR = (0.90, 0.10, 0.10, 1.0)  # and cleaning
#: An obstacle's fill (the markers' grey) and its outline.
OBSTACLE_FILL = tuple(round(c * 255) for c in OBSTACLE_RGBA[:3])
OBSTACLE_EDGE = (64, 64, 64)


def _pixel(colour: tuple[float, ...]) -> np.ndarray:
    """An RGBA colour in [0, 1] as an RGB pixel."""
    return (np.array(colour[:3]) * 255).astype(np.uint8)


def still_time(duration_ns: int, at: float | None) -> int:
    """The sim time (ns) of a still at ``at`` seconds (None: the end).

    Raises:
        AnimateError: ``at`` outside the episode.
    """
    if at is None:
        return duration_ns
    if not 0.0 <= at <= duration_ns / 1e9:
        raise AnimateError(f"the still's time {at:g} s is outside the episode "
                           f'(0 to {duration_ns / 1e9:g} s)')
    return round(at * 1e9)


def frame_times(duration_ns: int, speedup: float, fps: float) -> np.ndarray:
    """Sim times (ns) of the frames: ``round(duration / speedup * fps)`` frames (at least 2),
    the first at t = 0 and the last at the end, evenly spaced."""
    count = max(2, round(duration_ns / 1e9 / speedup * fps))
    return np.rint(np.linspace(0, duration_ns, count)).astype(np.int64)


class Renderer:
    """Draws frames of one episode: ``render(t_ns) -> [H, W, 3] uint8``.

    Args:
        record: the episode.
        width: frame width in pixels (the height is 9/16 of it, both even).
    """

    def __init__(self, record: Record, width: int = 1024) -> None:
        self.record = record
        setup = record.setup
        self.width = width - width % 16
        self.height = round(self.width / ASPECT / 16) * 16
        self.scale = self.width / 1024  # layout and fonts are designed at 1024 px
        self.states = setup.states  # the kind's state names and colours, as announced
        if not self.states:
            raise AnimateError("the episode's announcement names no controller states and its "
                               'controller.kind is not registered here (docs/extending.md, "A '
                               'controller")')
        self._layout()
        self.lut = (colormaps['viridis'](np.linspace(0, 1, 256))[:, :3] * 255).astype(np.uint8)
        # The cue, rebuilt from the episode's field by the cleaning record as time goes on.
        self.field = CueField(setup.world, setup.mona, setup.sensing)
        self.cue = self.field.cue
        self._next_event = 0
        self._time_ns = -1
        rows, cols = self.cue.shape
        top, left, h, w = self.map_box
        # Nearest-neighbour resampling of the raster into the map's pixels (row 0 at the top).
        self.map_rows = rows - 1 - (np.arange(h) * rows // h)
        self.map_cols = np.arange(w) * cols // w
        self.obstacle_fill, self.obstacle_edge = self._obstacle_pixels(h, w)
        radius = max(2.0, setup.mona.body_radius / setup.world.arena_side * w)
        r = math.ceil(radius)
        dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
        inside = dy ** 2 + dx ** 2 <= radius ** 2
        rim = inside & (dy ** 2 + dx ** 2 > (radius - max(1.0, radius / 4)) ** 2)
        self.disc = (dy[inside], dx[inside])
        self.rim = (dy[rim], dx[rim])
        self.colours = np.array([_pixel(state.colour) for state in self.states])
        font = font_manager.findfont('DejaVu Sans')
        self.font = ImageFont.truetype(font, max(10, round(22 * self.scale)))

    # --- the static parts, drawn once with matplotlib ---------------------------------------

    def _layout(self) -> None:
        record, setup = self.record, self.record.setup
        dpi = 64 * self.scale
        figure = Figure(figsize=(self.width / dpi, self.height / dpi), dpi=dpi)
        canvas = FigureCanvasAgg(figure)
        side = 0.80  # map height as a fraction of the figure
        map_ax = figure.add_axes((0.055, 0.08, side / ASPECT, side))
        arena = setup.world.arena_side
        map_ax.set_xlim(0, arena)
        map_ax.set_ylim(0, arena)
        map_ax.set_xlabel('x (m)')
        map_ax.set_ylabel('y (m)')
        speed = setup.parameters.get('controller', {}).get('speed')
        title = (f'N = {setup.population}'
                 + (f', v = {speed * 100:g} cm/s' if speed is not None else '')
                 + f', seed {setup.seed} ({record.runner})')
        figure.text(0.055, 0.965, title, fontsize=15, va='center')
        if record.states is not None:
            handles = [Patch(color=state.colour, label=state.name) for state in self.states]
        else:
            handles = [Patch(color=MOVING_COLOUR, label='moving'),
                       Patch(color=CLEANING_COLOUR, label='cleaning (no states recorded)')]
        figure.legend(handles=handles, loc='upper left', ncol=len(handles), frameon=False,
                      bbox_to_anchor=(0.53, 0.99), fontsize=12)
        axes = []
        duration = record.duration_ns / 1e9
        shown = plotted()
        pitch, height = PLOT_PITCH, PLOT_HEIGHT
        if len(shown) > 3:
            pitch = PLOT_COLUMN / len(shown)
            height = pitch - (PLOT_PITCH - PLOT_HEIGHT)
        for k, (name, label) in enumerate(shown):
            ax = figure.add_axes((0.60, 0.66 + PLOT_HEIGHT - height - k * pitch, 0.37, height))
            times, values = record.metrics.get(name, (np.zeros(0), np.zeros(0)))
            finite = values[np.isfinite(values)]
            # A fraction (no unit) spans 0..1.05; a quantity with a unit its own range.
            top = max(1.0, float(finite.max()) * 1.1) if METRICS[name].unit and len(finite) \
                else 1.05
            ax.set_xlim(0, duration)
            ax.set_ylim(0, top)
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
            if k < len(shown) - 1:
                ax.tick_params(labelbottom=False)
            else:
                ax.set_xlabel('sim time (s)')
            axes.append((ax, times / 1e9, values))
        canvas.draw()
        self.background = np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
        for ax, times, values in axes:
            ax.plot(times, values, color='tab:red', linewidth=2 * self.scale)
        canvas.draw()
        self.curves = np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
        self.map_box = self._box(map_ax, inset=1)
        self.plot_boxes = [self._box(ax, inset=0) for ax, _, _ in axes]
        self.plot_x = [(ax.transData.transform((0, 0))[0],
                        ax.transData.transform((duration, 0))[0]) for ax, _, _ in axes]
        self.clock_at = (round(0.055 * self.width), round(0.06 * self.height))

    def _box(self, ax, inset: int) -> tuple[int, int, int, int]:
        """(top, left, height, width) in pixels of an axes' inside."""
        x0, y0, x1, y1 = ax.get_window_extent().extents
        left, right = math.ceil(x0) + inset, math.floor(x1) - inset
        top, bottom = self.height - math.floor(y1) + inset, self.height - math.ceil(y0) - inset
        return top, left, bottom - top, right - left

    def _obstacle_pixels(self, h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
        """[h, w] masks of the map pixels whose centre an obstacle covers: (inside, outline)."""
        arena = self.record.setup.world.arena_side
        xs = (np.arange(w)[None, :] + 0.5) / w * arena
        ys = (1 - (np.arange(h)[:, None] + 0.5) / h) * arena  # row 0 at the top
        covered = np.zeros((h, w), dtype=bool)
        for obstacle in self.record.obstacles:
            covered |= obstacle.covers(xs, ys)
        inner = covered.copy()
        inner[1:, :] &= covered[:-1, :]
        inner[:-1, :] &= covered[1:, :]
        inner[:, 1:] &= covered[:, :-1]
        inner[:, :-1] &= covered[:, 1:]
        return inner, covered & ~inner

    # --- per frame -------------------------------------------------------------------------

    def cue_at(self, t_ns: int) -> np.ndarray:
        """The cue after every cleaning event up to ``t_ns`` (frames go forward in time)."""
        if t_ns < self._time_ns:
            raise ValueError('frames must be rendered in time order')
        events = self.record.cleaning
        while self._next_event < len(events) and events[self._next_event][0] <= t_ns:
            stamp, poses = events[self._next_event]
            self.field.clean_at(stamp, poses)
            self._next_event += 1
        self.field.advance_to(t_ns)
        self._time_ns = t_ns
        self.cue = self.field.cue
        return self.cue

    def map_pixels(self, cue: np.ndarray) -> np.ndarray:
        """The map's pixels for a cue raster (what the map shows without robots)."""
        # Colour the raster first, then resample it: two 1-D takes beat a 2-D fancy index.
        rgb = self.lut[np.clip(np.rint(cue), 0, 255).astype(np.uint8)]
        return np.take(np.take(rgb, self.map_rows, axis=0), self.map_cols, axis=1)

    def robot_colours(self, index: int, t_ns: int) -> np.ndarray:
        """[N, 3] uint8 colours of the robots at pose sample ``index``."""
        record = self.record
        if record.states is not None:
            return self.colours[np.minimum(record.states[index], len(self.colours) - 1)]
        # Without states: a robot that cleaned in the last cleaning period is shown waiting.
        poses = record.poses[index]
        colours = np.tile(_pixel(MOVING_COLOUR), (len(poses), 1))
        period = round(record.setup.world.cleaning_period * 1e9)
        k = self._next_event - 1  # the last event applied, at or before t_ns
        while k >= 0 and record.cleaning[k][0] > t_ns - period:
            cleaners = record.cleaning[k][1]
            k -= 1
            if len(cleaners):
                distance = np.hypot(poses[:, None, 0] - cleaners[None, :, 0],
                                    poses[:, None, 1] - cleaners[None, :, 1])
                colours[distance.argmin(axis=0)] = _pixel(CLEANING_COLOUR)
        return colours

    def render(self, t_ns: int) -> np.ndarray:
        """The frame at sim time ``t_ns`` (from the episode's start)."""
        cue = self.cue_at(t_ns)
        index = max(0, int(np.searchsorted(self.record.pose_times, t_ns, side='right')) - 1)
        return self.compose(cue, self.record.poses[index], self.robot_colours(index, t_ns),
                            t_ns)

    def compose(self, cue: np.ndarray, poses: np.ndarray, colours: np.ndarray,
                t_ns: int) -> np.ndarray:
        """The frame of a state: the cue raster, the robots' poses [N, 3] in their colours
        [N, 3] (uint8), at sim time ``t_ns`` (a learning environment's state, or a bag's)."""
        record, setup = self.record, self.record.setup
        frame = self.background.copy()
        top, left, h, w = self.map_box
        view = frame[top:top + h, left:left + w]
        view[:] = self.map_pixels(cue)
        view[self.obstacle_fill] = OBSTACLE_FILL
        view[self.obstacle_edge] = OBSTACLE_EDGE
        arena = setup.world.arena_side
        cols = np.rint(poses[:, 0] / arena * w).astype(np.int64)
        rows = np.rint((1 - poses[:, 1] / arena) * h).astype(np.int64)
        for (dy, dx), colour in ((self.disc, colours), (self.rim, None)):
            y = np.clip(rows[:, None] + dy[None, :], 0, h - 1)
            x = np.clip(cols[:, None] + dx[None, :], 0, w - 1)
            if colour is None:
                view[y, x] = 0
            else:
                view[y, x] = colour[:, None, :]
        # The metric curves, revealed up to t.
        t = t_ns / 1e9
        for (ptop, pleft, ph, pw), (x0, x1) in zip(self.plot_boxes, self.plot_x):
            reveal = min(pw, max(0, round(x0 + (x1 - x0) * t / (record.duration_ns / 1e9))
                                 - pleft + 1))
            frame[ptop:ptop + ph, pleft:pleft + reveal] = \
                self.curves[ptop:ptop + ph, pleft:pleft + reveal]
        # The clock and the progress bar.
        bar_top = self.height - max(4, round(8 * self.scale))
        frame[bar_top:, :round(self.width * t_ns / max(record.duration_ns, 1))] = (214, 39, 40)
        x, y = self.clock_at
        strip = Image.fromarray(frame[y - 2:y + self.font.size + 6, x:x + 14 * self.font.size])
        duration = record.duration_ns / 1e9
        clock = f'{t:.0f}' if duration >= 100 else f'{t:.1f}'
        ImageDraw.Draw(strip).text((0, 0), f't = {clock} s of {duration:g} s', fill=(0, 0, 0),
                                   font=self.font)
        frame[y - 2:y + self.font.size + 6, x:x + 14 * self.font.size] = np.asarray(strip)
        return frame

    def frames(self, times: np.ndarray) -> Iterator[np.ndarray]:
        """The frames at ``times`` (increasing)."""
        for t in times:
            yield self.render(int(t))


def animate(path: str | Path, out: str | Path, *, speedup: float = 100.0, fps: float = 25.0,
            width: int | None = None, at: float | None = None,
            progress: Callable[[int, int], None] | None = None) -> dict:
    """Render the episode of a bag (or an episode folder holding ``bag/``) into a video, or
    one frame of it into a still picture.

    Args:
        path: an episode folder, a bag directory or its .mcap.
        out: ``.mp4`` (H.264), ``.gif``, or ``.png`` (one frame, at ``at``).
        speedup: sim seconds per video second.
        fps: frames per video second.
        width: frame width in pixels (default 1024 for MP4, 640 for GIF, 1280 for PNG).
        at: a still's sim time in seconds (default: the end); only for ``.png``.
        progress: called with (frames done, frames in all) after each frame.

    Returns:
        What was written: path, frames, fps, speedup, width, height, seconds of sim time
        (``duration_s``) and the first frame's time (``first_s``: a still's time).

    Raises:
        AnimateError: bad input or output name.
        BagError: a damaged or cut-short bag.
    """
    out = Path(out)
    kind = out.suffix.lower()
    if kind not in DEFAULT_WIDTH:
        raise AnimateError(f'{out}: the output must end in .mp4 or .gif (a video) or .png '
                           '(a still)')
    if at is not None and kind != '.png':
        raise AnimateError(f'{out}: a time (at = {at:g} s) is for a still (.png), not a video')
    record = read_record(path)
    renderer = Renderer(record, width or DEFAULT_WIDTH[kind])
    if kind == '.png':
        times = np.array([still_time(record.duration_ns, at)], dtype=np.int64)
    else:
        times = frame_times(record.duration_ns, speedup, fps)
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(out.stem + '.partial' + out.suffix)
    done = 0

    def counted() -> Iterator[np.ndarray]:
        nonlocal done
        for frame in renderer.frames(times):
            yield frame
            done += 1
            if progress is not None:
                progress(done, len(times))

    try:
        if kind == '.mp4':
            _write_mp4(partial, counted(), fps)
        elif kind == '.gif':
            _write_gif(partial, counted(), fps)
        else:
            Image.fromarray(next(counted())).save(partial, format='PNG', optimize=True)
    except BaseException:
        partial.unlink(missing_ok=True)  # no half video left behind
        raise
    partial.replace(out)  # a video is there only once it is whole
    return {'path': str(out), 'frames': len(times), 'fps': fps, 'speedup': speedup,
            'width': renderer.width, 'height': renderer.height,
            'duration_s': record.duration_ns / 1e9, 'first_s': int(times[0]) / 1e9}


def _write_mp4(path: Path, frames: Iterator[np.ndarray], fps: float) -> None:
    import imageio_ffmpeg  # the wheel carries its own ffmpeg

    writer = None
    for frame in frames:
        if writer is None:
            writer = imageio_ffmpeg.write_frames(
                str(path), (frame.shape[1], frame.shape[0]), fps=fps, codec='libx264',
                quality=7, macro_block_size=16, pix_fmt_out='yuv420p',
                ffmpeg_log_level='error', output_params=['-preset', 'veryfast'])
            writer.send(None)  # start the generator
        writer.send(np.ascontiguousarray(frame))
    if writer is not None:
        writer.close()


def _write_gif(path: Path, frames: Iterator[np.ndarray], fps: float) -> None:
    images = [Image.fromarray(frame).quantize(colors=128, method=Image.Quantize.MEDIANCUT,
                                              dither=Image.Dither.NONE) for frame in frames]
    images[0].save(path, format='GIF', save_all=True, append_images=images[1:],
                   duration=round(1000 / fps), loop=0, optimize=True)

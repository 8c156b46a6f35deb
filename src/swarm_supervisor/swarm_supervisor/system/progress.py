"""How far a node-system run is: the supervisor writes ``<out>/progress.json`` from the world's
``/world/status`` (at most once a wall second, atomically), and the launcher turns it into its
progress line on stderr every ~10 s::

    mona-swarm launch: episode 1/2, sim 120/600 s, 85 steps/s, 3 misses, ETA 9 min 25 s

Pure (no ROS): the supervisor node hands in the statuses it receives.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

from mona_controller.contract import WorldStatus

PROGRESS_FILE = 'progress.json'


class ProgressFile:
    """Writes ``<folder>/progress.json`` from the world's statuses, at most every ``every``
    wall seconds (and at each change of episode or state), by rename: a reader never sees
    half a file."""

    def __init__(self, folder: Path, episodes: int, duration: float,
                 every: float = 1.0) -> None:
        self.path = Path(folder) / PROGRESS_FILE
        self.episodes = episodes
        self.duration = duration
        self.every = every
        self.written = -math.inf
        self.last: tuple[int, str] | None = None

    def note(self, status: WorldStatus) -> bool:
        """Write ``status`` if it is time to; True if written."""
        now = time.monotonic()
        key = (status.episode, status.state.value)
        if now - self.written < self.every and key == self.last:
            return False
        self.written, self.last = now, key
        document = {'episode': status.episode, 'episodes': self.episodes,
                    'state': status.state.value, 'step': status.step, 'steps': status.steps,
                    'duration': self.duration, 'misses': sum(status.misses),
                    'absent': len(status.absent), 'wall': time.time()}
        partial = self.path.with_name(PROGRESS_FILE + '.partial')
        partial.parent.mkdir(parents=True, exist_ok=True)
        partial.write_text(json.dumps(document) + '\n')
        os.replace(partial, self.path)
        return True


def read_progress(folder: Path) -> dict | None:
    """The latest ``progress.json`` of a run, or None (not yet written, or unreadable)."""
    try:
        document = json.loads((Path(folder) / PROGRESS_FILE).read_text())
    except (OSError, ValueError):
        return None
    return document if isinstance(document, dict) else None


def duration_text(seconds: float) -> str:
    """'45 s', '9 min 25 s', '2 h 05 min'."""
    seconds = int(round(seconds))
    if seconds < 60:
        return f'{seconds} s'
    if seconds < 3600:
        return f'{seconds // 60} min {seconds % 60} s'
    return f'{seconds // 3600} h {seconds % 3600 // 60:02d} min'


class ProgressLine:
    """The launcher's progress line from successive ``progress.json`` documents: the speed
    (steps per wall second) is over the interval since the previous document it was shown."""

    def __init__(self) -> None:
        self.previous: tuple[float, int] | None = None  # (wall, steps done in the run)

    def line(self, document: dict | None, waited: float) -> str:
        """The line for ``document`` (None: no status yet) ``waited`` wall seconds into the
        run."""
        if document is None:
            return f'waiting for the world ({duration_text(waited)} since the start)'
        try:
            episode, episodes = int(document['episode']), int(document['episodes'])
            step, steps = int(document['step']), int(document['steps'])
            duration, wall = float(document['duration']), float(document['wall'])
            state, misses = str(document['state']), int(document['misses'])
        except (KeyError, TypeError, ValueError):
            return 'no progress (unreadable progress.json)'
        if episode < 0 or state == 'waiting':
            shown = max(episode, 0) + 1
            return (f'episode {shown}/{episodes}: waiting for the controllers and the metrics '
                    f'node ({duration_text(waited)} since the start)')
        done = episode * steps + step
        sim = duration * step / steps if steps else 0.0
        parts = [f'episode {episode + 1}/{episodes}', f'sim {sim:.0f}/{duration:g} s']
        if self.previous is not None and wall > self.previous[0] and done >= self.previous[1]:
            rate = (done - self.previous[1]) / (wall - self.previous[0])
            parts.append(f'{rate:.0f} steps/s')
            parts.append(f'{misses} misses')
            left = episodes * steps - done
            parts.append(f'ETA {duration_text(left / rate)}' if rate > 0 else 'ETA unknown')
        else:
            parts.append(f'{misses} misses')
        self.previous = (wall, done)
        return ', '.join(parts)

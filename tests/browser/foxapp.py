"""The Foxglove web app in a real browser, as the tests open and read it.

:func:`app_url` makes the deep link that opens a bag (``ds=remote-file``) or the live view
(``ds=foxglove-websocket``) with our layout, no clicks; :class:`FoxgloveApp` waits until it
shows data and gathers what a person looks at into a :class:`View`: screenshots of the 3D,
image and plot panels, the text of the plots' legends, the announcement and status panels,
the app's problem list and the playback clock.
"""

from __future__ import annotations

import contextlib
import io
import re
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlencode

import numpy as np
from PIL import Image
from playwright.sync_api import TimeoutError as PlaywrightTimeout

#: The layout's panels the checks read (their ids in ros_ws/config/foxglove_layout.json).
SCENE, CUE_MAP, EPISODE, STATUS = '3D!arena', 'ImageViewPanel!cue', 'RawMessages!episode', \
    'RawMessages!status'
LAYOUT_ID = 'mona-swarm'  # tests/browser/app/mount.js
#: Per panel id: its text and the box (x, y, width, height) of its largest canvas, or null.
PANELS_JS = """(ids) => Object.fromEntries(ids.map((id) => {
  const panel = document.querySelector(`[data-testid="panel-mouseenter-container ${id}"]`);
  if (!panel) { return [id, {text: '', canvas: null}]; }
  let best = null;
  for (const canvas of panel.querySelectorAll('canvas')) {
    const r = canvas.getBoundingClientRect();
    if (r.width * r.height > 0 && (!best || r.width * r.height > best[2] * best[3])) {
      best = [r.x, r.y, r.width, r.height];
    }
  }
  return [id, {text: panel.innerText, canvas: best}];
}))"""


def app_url(base: str, source: str, seek_s: float | None = None) -> str:
    """The page's URL opening ``source`` (a bag's URL, or a ``ws://`` live view) with the
    layout; ``seek_s`` seeks a bag to that sim time (the bag's log time is sim time)."""
    if source.startswith('ws://'):
        query = {'ds': 'foxglove-websocket', 'ds.url': source}
    else:
        query = {'ds': 'remote-file', 'ds.url': source}
    query['layoutId'] = LAYOUT_ID
    if seek_s is not None:
        whole, frac = divmod(round(seek_s * 1e9), 1_000_000_000)
        stamp = time.strftime('%Y-%m-%dT%H:%M:%S', time.gmtime(whole))
        query['time'] = f'{stamp}.{frac:09d}Z'
    return f'{base}/app/index.html?{urlencode(query)}'


def png(data: bytes) -> np.ndarray:
    """A screenshot's PNG bytes as an RGB uint8 array."""
    return np.asarray(Image.open(io.BytesIO(data)).convert('RGB'))


def status_seconds(text: str) -> float | None:
    """The sim time (s) of the status a Raw Messages panel shows (its ``time_ns``)."""
    match = re.search(r'"time_ns": (\d+)', text)
    return int(match.group(1)) / 1e9 if match else None


def running_seconds(text: str) -> float | None:
    """The sim time (s) of a status panel's text if it shows a running episode, else None."""
    return status_seconds(text) if '"state": "running"' in text else None


def clock_seconds(text: str) -> float | None:
    """Sim seconds of the playback clock's text (``12:02:30.000 AM UTC``: the time of day of
    a sim time near the epoch), or None when it shows none."""
    match = re.search(r'(\d{1,2}):(\d{2}):(\d{2})\.(\d{3})\s*(AM|PM)', text)
    if not match:
        return None
    hours, minutes, seconds, millis, half = match.groups()
    return (int(hours) % 12 + (12 if half == 'PM' else 0)) * 3600 + int(minutes) * 60 + \
        int(seconds) + int(millis) / 1000


@dataclass
class View:
    """What the app showed at one moment."""

    scene: np.ndarray          # the 3D panel's canvas
    cue_map: np.ndarray        # the image panel's canvas
    plots: dict[str, tuple[str, np.ndarray]] = field(default_factory=dict)  # id: text, pixels
    episode_text: str = ''     # the announcement's Raw Messages panel
    status_text: str = ''      # the status's
    problems: str = ''         # the Problems tab of the data source sidebar
    clock: float | None = None  # the playback clock (a bag), sim seconds
    status_time: float | None = None  # the shown status's sim time, seconds
    topics: str = ''           # the Topics tab


class FoxgloveApp:
    """One page of the app: open a source, wait for it, look at it, save screenshots."""

    def __init__(self, browser, shots: Path) -> None:
        """A new page of ``browser`` (a Playwright browser context); screenshots go to
        ``shots``."""
        self.page = browser.new_page()
        self.shots = shots
        self.console: list[str] = []
        self.page.on('console', lambda msg: self.console.append(f'{msg.type}: {msg.text}'))
        self.page.on('pageerror', lambda error: self.console.append(f'pageerror: {error}'))

    def close(self) -> None:
        """Close the page."""
        self.page.close()

    def open(self, url: str, timeout: float = 120.0) -> float:
        """Load ``url`` and wait until the data source is up and every panel of the layout
        is mounted; returns the seconds it took."""
        start = time.monotonic()
        deadline = start + timeout
        waiting_for = 'the page to load'
        try:
            self.page.goto(url, wait_until='load', timeout=timeout * 1000)
            for panel in (SCENE, CUE_MAP, EPISODE, STATUS):
                waiting_for = f'panel {panel} to mount'
                self.panel(panel).wait_for(
                    timeout=max(1.0, deadline - time.monotonic()) * 1000)
            # The data source sidebar lists topics once the player is up, on its Topics tab:
            # Foxglove turns to the Problems tab when the player reports a problem (a transient
            # one too), which hides the list, so show the Topics tab before each look. The
            # list draws only the rows in view, and /world/status sorts near its end: filter
            # the list to it, then clear the filter.
            waiting_for = 'the data source to list /world/status'
            self.wait_listed('/world/status', deadline)
        except PlaywrightTimeout as error:
            # What the page showed and said: the next failure names its cause.
            shot = self.save('open_timed_out')
            said = '\n'.join(self.console[-15:]) or '(nothing)'
            raise AssertionError(
                f'{url}: waited {time.monotonic() - start:.0f} s for {waiting_for}; the page '
                f'is in {shot}; its last console messages:\n{said}') from error
        error = self.page.evaluate('window.monaSwarmMountError || ""')
        if error:
            raise RuntimeError(f'the page could not mount the app: {error}')
        self.dismiss_tips()
        return time.monotonic() - start

    def wait_listed(self, topic: str, deadline: float) -> None:
        """Wait until the data source sidebar's Topics tab lists ``topic`` (by the monotonic
        ``deadline``), its filter set to the topic meanwhile and cleared after."""
        search = self.page.get_by_placeholder('Filter by topic')
        # Visible ones only: the first in the page's order may be a hidden copy of the text.
        listed = self.page.get_by_text(topic, exact=True).filter(visible=True).first
        try:
            while True:
                self.show_tab('Topics')
                if search.count():
                    search.first.fill(topic)
                try:
                    listed.wait_for(timeout=2000)
                    return
                except PlaywrightTimeout:
                    if time.monotonic() > deadline:
                        raise
        finally:
            if search.count():
                search.first.fill('')

    def dismiss_tips(self) -> None:
        """Close the 3D panel's first-use tooltip ("Open settings ...") if it is shown."""
        tip = self.page.get_by_text('Open settings to configure topics and layers.')
        if tip.count():
            close = self.page.locator('[data-testid="CloseIcon"]')
            if close.count():
                close.first.click()

    def panel(self, panel_id: str):
        """The locator of a layout panel by id."""
        return self.page.locator(f'[data-testid="panel-mouseenter-container {panel_id}"]')

    def text(self, panel_id: str) -> str:
        """A panel's visible text."""
        return self.panel(panel_id).inner_text()

    def show_tab(self, name: str) -> bool:
        """Click a tab of the data source sidebar (Topics, Problems) if it is shown; whether
        it was."""
        tab = self.page.get_by_role('tab', name=name)
        if tab.count() == 0:
            tab = self.page.get_by_text(name, exact=True)
        if tab.count() == 0:
            return False
        tab.first.click()
        return True

    def sidebar_tab(self, name: str) -> str:
        """Click a tab of the data source sidebar (Topics, Problems) and return its text."""
        assert self.show_tab(name), f'the data source sidebar shows no {name} tab'
        self.page.wait_for_timeout(300)
        return self.page.locator('[role="tabpanel"]').first.inner_text() \
            if self.page.locator('[role="tabpanel"]').count() else self.page.inner_text('body')

    def clock(self) -> float | None:
        """The playback clock in sim seconds (None while it shows no time)."""
        clock = self.page.locator('[data-testid="PlaybackTime-text"]')
        if clock.count() == 0:
            return None
        field = clock.locator('input')
        return clock_seconds(field.first.input_value() if field.count() else clock.inner_text())

    def look(self, plots: list[str]) -> View:
        """Everything the checks need, read now: one screenshot of the page, cut to each
        panel's largest canvas (what it draws, without its toolbar), and the panels' text."""
        ids = [SCENE, CUE_MAP, EPISODE, STATUS, *plots]
        panels = self.page.evaluate(PANELS_JS, ids)
        shot = png(self.page.screenshot())

        def cut(panel_id: str) -> np.ndarray:
            box = panels[panel_id]['canvas']
            if box is None:
                return np.zeros((0, 0, 3), dtype=np.uint8)
            x, y, w, h = (int(round(v)) for v in box)
            return shot[max(0, y):y + h, max(0, x):x + w]

        view = View(scene=cut(SCENE), cue_map=cut(CUE_MAP))
        for plot in plots:
            view.plots[plot] = (panels[plot]['text'], cut(plot))
        view.episode_text = panels[EPISODE]['text']
        view.status_text = panels[STATUS]['text']
        view.status_time = status_seconds(view.status_text)
        view.clock = self.clock()
        view.topics = self.sidebar_tab('Topics')
        view.problems = self.sidebar_tab('Problems')
        self.sidebar_tab('Topics')
        return view

    @contextlib.contextmanager
    def minimised(self) -> Iterator[None]:
        """The page's window minimised meanwhile, as when a user switches to another window:
        the page keeps its connection and its scripts run (the panels' text keeps up), but
        chromium composites no frames, so the 3D panel is not redrawn in software at more than
        a core (2026-12-05, a live page: 18 -> 3 CPU-s per 10 s)."""
        cdp = self.page.context.new_cdp_session(self.page)
        window = cdp.send('Browser.getWindowForTarget')['windowId']
        cdp.send('Browser.setWindowBounds',
                 {'windowId': window, 'bounds': {'windowState': 'minimized'}})
        try:
            yield
        finally:
            cdp.send('Browser.setWindowBounds',
                     {'windowId': window, 'bounds': {'windowState': 'normal'}})
            cdp.detach()

    def save(self, name: str) -> Path:
        """A full-page screenshot ``<shots>/<name>.png``."""
        self.shots.mkdir(parents=True, exist_ok=True)
        path = self.shots / f'{name}.png'
        self.page.screenshot(path=str(path))
        return path

    def sim_time_advances(self, duration: float, timeout: float = 30.0) -> tuple[float, float]:
        """Right after :meth:`open`, while the episode runs: the sim time (s) of the running
        status the status panel shows, and of a later status within ``timeout`` s (at most
        ``duration``, the episode's end). Only the panel's text is read (no screenshots),
        so a slow machine loses no time before both."""
        first = self.wait_until(lambda: running_seconds(self.text(STATUS)),
                                'the status of a running episode', timeout)
        later = self.wait_until(lambda: (status_seconds(self.text(STATUS)) or 0) > first and
                                status_seconds(self.text(STATUS)), 'a later status', timeout)
        assert first < later <= duration, (first, later, duration)
        return first, later

    def wait_until(self, condition, what: str, timeout: float = 60.0, every: float = 1.0):
        """Poll ``condition()`` (truthy result returned) until ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while True:
            result = condition()
            if result:
                return result
            if time.monotonic() > deadline:
                shot = self.save('never_showed')
                raise AssertionError(f'the app never showed {what} in {timeout:.0f} s; the '
                                     f'status panel shows {self.text(STATUS)!r}; the page is '
                                     f'in {shot}')
            self.page.wait_for_timeout(every * 1000)

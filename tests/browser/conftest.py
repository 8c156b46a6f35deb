"""Fixtures of the browser tier: the tools (skipped, naming what is missing, where they
cannot be installed: a failure of the run under CI=true), the page server and one headless
Debian chromium per pytest process, and the folder that keeps a module's screenshots."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest
from httpserve import Server, Site

REPO = Path(__file__).resolve().parents[2]
APP = Path(__file__).resolve().parent / 'app'
LAYOUT = REPO / 'ros_ws' / 'config' / 'foxglove_layout.json'
#: Where `make browser-tools` installs the Foxglove web build (outside the checkout).
CACHE = Path(os.environ.get('MONA_SWARM_FOXGLOVE_CACHE',
                            Path.home() / '.cache' / 'mona-swarm' / 'foxglove'))
CHROMIUM = Path(os.environ.get('MONA_SWARM_CHROMIUM', '/usr/bin/chromium'))
#: Screenshots of a run: results/browser/<test module>/ (printed by each test).
SHOTS = Path(os.environ.get('MONA_SWARM_BROWSER_SHOTS', REPO / 'results' / 'browser'))


def missing_tools() -> list[str]:
    """What the browser tests need and this machine lacks (make browser-tools installs it)."""
    missing = []
    if not CHROMIUM.exists():
        missing.append(f'{CHROMIUM} (Debian package chromium)')
    bundle = CACHE / 'node_modules' / '@foxglove' / 'studio-base' / 'assets' / 'index.js'
    for part in (bundle, CACHE / 'node_modules' / 'react' / 'umd',
                 CACHE / 'node_modules' / 'react-dom' / 'umd'):
        if not part.exists():
            missing.append(f'{part} (npm: make browser-tools)')
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        missing.append('the playwright Python package (requirements.txt)')
    return missing


@pytest.fixture(scope='session')
def tools() -> None:
    """Skip the browser tests, naming what is missing, when the tools are not installed."""
    missing = missing_tools()
    if missing:
        pytest.skip('browser tools not installed: ' + '; '.join(missing) +
                    ': make browser-tools installs them (as root)')


@pytest.fixture(scope='session')
def browser(tools: None) -> Iterator[object]:
    """One headless Debian chromium (WebGL2 in software: SwiftShader), as one browser
    profile every page opens in: the build is fetched and compiled once.

    Only WebGL goes through SwiftShader: the page's raster, compositing and 2D canvases (the
    plots) are Skia's on the CPU, which costs far less than emulating a GPU for them
    (2026-12-05, a live page at 10 poses/s: 1.8 -> 1.3 cores; opening a bag 12.6 -> 5.0
    CPU-s, a look 2.3 -> 0.7)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(
            executable_path=str(CHROMIUM), headless=True,
            args=['--no-sandbox', '--disable-dev-shm-usage', '--use-angle=swiftshader',
                  '--enable-unsafe-swiftshader', '--disable-gpu-rasterization',
                  '--disable-gpu-compositing', '--disable-accelerated-2d-canvas'])
        # One profile for every page: they share the browser's cache of the build.
        context = chromium.new_context(viewport={'width': 1600, 'height': 1000})
        try:
            yield context
        finally:
            context.close()
            chromium.close()


@pytest.fixture(scope='module')
def shots(request: pytest.FixtureRequest) -> Path:
    """results/browser/<module>/, emptied: the screenshots this module's tests take."""
    folder = SHOTS / request.module.__name__.rpartition('.')[2]
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    print(f'\nscreenshots: {folder}')
    return folder


@pytest.fixture(scope='session')
def data_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder served under /data/ (the bags the tests open)."""
    return tmp_path_factory.mktemp('data')


@pytest.fixture(scope='session')
def server(tools: None, data_dir: Path) -> Iterator[Server]:
    """The page, the Foxglove build, the module's bags and the layout, over HTTP with ranges."""
    with Server(Site({'app': APP, 'foxglove': CACHE, 'data': data_dir}, LAYOUT,
                     cached='foxglove')) as served:
        yield served

"""The browser tier's own parts, without a browser: the range server with a real HTTP client,
and the pixel checks on pictures drawn here (a centred arena passes, a shifted one fails)."""

from __future__ import annotations

import http.client
from pathlib import Path

import numpy as np
import pixels
import pytest
from checks import SIDE, Expected, scene_findings
from httpserve import Server, Site, parse_range


@pytest.fixture
def served(tmp_path: Path):
    data = tmp_path / 'data'
    data.mkdir()
    (data / 'bag.mcap').write_bytes(bytes(range(256)) * 4)  # 1024 bytes
    layout = tmp_path / 'layout.json'
    layout.write_text('{"configById": {}}')
    (tmp_path / 'secret').write_text('not served')
    with Server(Site({'data': data}, layout)) as server:
        yield server


def get(server: Server, path: str, headers: dict[str, str] | None = None,
        method: str = 'GET') -> tuple[int, dict[str, str], bytes]:
    host, port = server.httpd.server_address[:2]
    connection = http.client.HTTPConnection(str(host), int(port), timeout=10)
    try:
        connection.request(method, path, headers=headers or {})
        response = connection.getresponse()
        return response.status, dict(response.getheaders()), response.read()
    finally:
        connection.close()


def test_a_range_request_gets_exactly_its_bytes(served):
    status, headers, body = get(served, '/data/bag.mcap', {'Range': 'bytes=250-261'})
    assert status == 206
    assert headers['Content-Range'] == 'bytes 250-261/1024'
    assert body == bytes([250, 251, 252, 253, 254, 255, 0, 1, 2, 3, 4, 5])
    status, headers, body = get(served, '/data/bag.mcap', {'Range': 'bytes=-4'})
    assert (status, body) == (206, bytes([252, 253, 254, 255]))


def test_a_whole_file_says_it_takes_ranges_and_its_length(served):
    status, headers, body = get(served, '/data/bag.mcap')
    assert status == 200 and len(body) == 1024
    assert headers['Accept-Ranges'] == 'bytes' and headers['Content-Length'] == '1024'
    status, headers, body = get(served, '/data/bag.mcap', method='HEAD')
    assert (status, body, headers['Content-Length']) == (200, b'', '1024')


def test_bad_ranges_and_paths_outside_the_mounts_are_refused(served):
    status, headers, _ = get(served, '/data/bag.mcap', {'Range': 'bytes=2000-2010'})
    assert status == 416 and headers['Content-Range'] == 'bytes */1024'
    assert get(served, '/data/../secret')[0] == 404
    assert get(served, '/elsewhere/bag.mcap')[0] == 404
    assert get(served, '/layout.json')[2] == b'{"configById": {}}'


def test_parse_range():
    assert parse_range('bytes=0-0', 10) == (0, 0)
    assert parse_range('bytes=5-', 10) == (5, 9)
    assert parse_range('bytes=8-100', 10) == (8, 9)
    assert parse_range('bytes=-3', 10) == (7, 9)
    for bad in ('bytes=10-', 'bytes=5-2', 'bytes=-0', 'bytes=-', 'items=0-1', 'bytes=0-1,3-4'):
        assert parse_range(bad, 10) is None, bad


def picture(arena_at: tuple[int, int], side: int = 300, size: tuple[int, int] = (400, 500),
            robots: np.ndarray | None = None) -> np.ndarray:
    """A top-down view as the layout draws it: dark floor, yellow outline, green robots with a
    white tick, one magenta source."""
    height, width = size
    image = np.full((height, width, 3), 32, dtype=np.uint8)
    x0, y0 = arena_at
    yellow = (255, 240, 0)
    image[y0:y0 + 3, x0:x0 + side] = image[y0 + side - 3:y0 + side, x0:x0 + side] = yellow
    image[y0:y0 + side, x0:x0 + 3] = image[y0:y0 + side, x0 + side - 3:x0 + side] = yellow
    box = pixels.Box(x0, y0, x0 + side, y0 + side)
    radius = 0.04 / SIDE * side
    yy, xx = np.mgrid[0:height, 0:width]
    for px, py in pixels.to_pixels(robots, box, SIDE):
        disc = (xx - px) ** 2 + (yy - py) ** 2 <= radius ** 2
        image[disc] = (59, 199, 71)
        image[int(py), int(px):int(px + radius)] = (255, 255, 255)
    sx, sy = pixels.to_pixels(np.array([[1.425, 1.425]]), box, SIDE)[0]
    image[(xx - sx) ** 2 + (yy - sy) ** 2 <= radius ** 2] = (217, 0, 217)
    return image


ROBOTS = np.array([[0.5, 0.5], [2.0, 0.7], [1.0, 2.3], [2.5, 2.5]])


def test_a_centred_arena_with_its_robots_passes():
    image = picture((100, 50), robots=ROBOTS)
    expected = Expected(population=4, seed=0, mode='embedded', plots={}, positions=ROBOTS,
                        states=np.zeros(4, dtype=np.uint8), sources=np.array([[1.425, 1.425]]))
    assert scene_findings(image, expected) == []


def test_a_shifted_arena_and_misplaced_or_miscoloured_robots_fail():
    expected = Expected(population=4, seed=0, mode='embedded', plots={}, positions=ROBOTS,
                        states=np.zeros(4, dtype=np.uint8))
    shifted = scene_findings(picture((10, 10), robots=ROBOTS), expected)
    assert any('not centred' in line for line in shifted)
    moved = scene_findings(picture((100, 50), robots=ROBOTS[::-1] * [1, 0.5]), expected)
    assert any('no robot disc where robots' in line for line in moved)
    waiting = Expected(**{**expected.__dict__, 'states': np.full(4, 2, dtype=np.uint8)})
    assert any("states' colours" in line
               for line in scene_findings(picture((100, 50), robots=ROBOTS), waiting))
    empty = np.full((400, 500, 3), 32, dtype=np.uint8)
    assert scene_findings(empty, expected) == ['the 3D panel shows no arena outline']


def test_hues_of_the_layout_colours():
    swatch = np.array([[(59, 199, 71), (255, 160, 8), (238, 37, 36), (64, 115, 255),
                        (255, 240, 0), (0, 188, 212), (217, 0, 217), (230, 230, 230)]],
                      dtype=np.uint8)
    found = {name: np.nonzero(pixels.hue_mask(swatch, hue)[0])[0].tolist()
             for name, hue in {**pixels.STATE_HUES, 'outline': pixels.OUTLINE_HUE,
                               'obstacle': pixels.OBSTACLE_HUE,
                               'source': pixels.SOURCE_HUE}.items()}
    # Each colour is found by its own hue only; the grey ramp by none.
    assert found == {'follow': [0], 'avoid': [1], 'wait': [2], 'turn': [3], 'outline': [4],
                     'obstacle': [5], 'source': [6]}

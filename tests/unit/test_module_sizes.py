"""No module of the four packages grows past 400 lines (one job a module)."""

from __future__ import annotations

from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / 'src'
PACKAGES = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor')
LIMIT = 400


def test_no_module_is_over_the_limit():
    sizes = {path.relative_to(SRC).as_posix(): len(path.read_text().splitlines())
             for package in PACKAGES for path in (SRC / package / package).rglob('*.py')}
    assert all(any(name.startswith(f'{package}/{package}/') for name in sizes)
               for package in PACKAGES), sorted(sizes)
    over = {name: lines for name, lines in sizes.items() if lines > LIMIT}
    assert not over, f'modules over {LIMIT} lines (split them by job): {over}'

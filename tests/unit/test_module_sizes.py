"""No module of swarm_supervisor's sub-packages grows past 400 lines (one job a module)."""

from __future__ import annotations

from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / 'src' / 'swarm_supervisor' / 'swarm_supervisor'
LIMIT = 400


def test_no_supervisor_module_is_over_the_limit():
    sizes = {path.relative_to(PACKAGE).as_posix(): len(path.read_text().splitlines())
             for path in PACKAGE.rglob('*.py')}
    assert sizes, PACKAGE
    over = {name: lines for name, lines in sizes.items() if lines > LIMIT}
    assert not over, f'modules over {LIMIT} lines (split them by job): {over}'

"""The docs speak to someone who was not here: no page, shipped parameter file or design
refers to this project's issue tracker ("issue 22", "the issue's aim"); a reader cannot look
those up. Other projects' issues, named with their repository, are fine."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
OURS = re.compile(r"\b[Ii]ssue \d+\b|\bthe issue('s)?\b|\bissue's\b")


def test_no_page_or_shipped_file_names_our_issues():
    files = [REPO / 'README.md', *sorted((REPO / 'docs').glob('*.md')),
             *sorted((REPO / 'ros_ws' / 'config').rglob('*.yaml'))]
    found = [f'{path.relative_to(REPO)}:{number}: {line.strip()}'
             for path in files
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if OURS.search(line)]
    assert not found, '\n'.join(found)

"""docs/architecture.md's module tree is true to the code: every module of the four packages is
named in it, at its place, and every module it names exists."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SRC = REPO / 'src'
PACKAGES = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor')
MODULE = re.compile(r'\b(\w+\.py)\b')


def tree() -> dict[str, dict[str, set[str]]]:
    """Package -> entry (a top-level module, or a folder with a trailing /) -> the modules the
    entry names (itself, or those its description names), from the first code block."""
    text = (REPO / 'docs' / 'architecture.md').read_text()
    block = text.split('```\n', 2)[1]
    found: dict[str, dict[str, set[str]]] = {}
    package = entry = None
    for line in block.splitlines():
        head = re.match(r'  (\w+)/(\w+)/\s', line)
        if head and head.group(1) == head.group(2):
            package, entry = head.group(1), None
            found[package] = {}
            continue
        if not line.startswith('    '):
            package = entry = None  # the end of the packages (examples/, ...)
            continue
        if package is None:
            continue
        if not line.startswith('     '):  # an entry: its name, then its description
            entry, _, line = line.strip().partition(' ')
            found[package][entry] = {entry} if entry.endswith('.py') else set()
        if entry is not None and entry.endswith('/'):
            found[package][entry] |= set(MODULE.findall(line))
    return found


def code() -> dict[str, dict[str, set[str]]]:
    """The same from the source tree (a folder's modules by file name, its own sub-folders'
    included; faces, __init__.py, left out)."""
    found: dict[str, dict[str, set[str]]] = {}
    for package in PACKAGES:
        root = SRC / package / package
        entries: dict[str, set[str]] = {}
        for path in sorted(root.rglob('*.py')):
            if path.name == '__init__.py' or '__pycache__' in path.parts:
                continue
            parts = path.relative_to(root).parts
            if len(parts) == 1:
                entries[parts[0]] = {parts[0]}
            else:
                entries.setdefault(parts[0] + '/', set()).add(path.name)
        found[package] = entries
    return found


def test_the_tree_names_every_module_where_it_lives():
    documented, actual = tree(), code()
    assert set(documented) == set(PACKAGES), set(documented)
    problems = []
    for package in PACKAGES:
        named, there = documented[package], actual[package]
        for entry in sorted(set(named) | set(there)):
            missing = there.get(entry, set()) - named.get(entry, set())
            extra = named.get(entry, set()) - there.get(entry, set())
            if missing:
                problems.append(f'{package}/{entry}: not in the tree: {sorted(missing)}')
            if extra:
                problems.append(f'{package}/{entry}: in the tree, not in the code: '
                                f'{sorted(extra)}')
    assert not problems, '\n'.join(problems)

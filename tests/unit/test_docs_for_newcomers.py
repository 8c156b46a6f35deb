"""The docs speak to someone who was not here: no page, shipped parameter file, design, module,
test or script refers to this project's issue tracker ("issue 22", "the issue's aim"); a reader
cannot look those up. Other projects' issues, named with their repository, are fine. Every
relative link of the pages leads to a file that is there, and the glossary defines the words
the pages lean on."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
OURS = re.compile(r"\b[Ii]ssue \d+\b|\bthe issue('s)?\b|\bissue's\b")


PAGES = [REPO / 'README.md', *sorted((REPO / 'docs').glob('*.md'))]
#: Markdown links to files of the repository: [text](target) with no scheme.
LINK = re.compile(r'\]\(((?![a-z]+:)[^)\s#]+)(#[^)\s]*)?\)')
#: Words the pages use in a sense of their own, and the glossary's entry for each.
TERMS = ('absent', 'announcement', 'bag', 'CDR', 'cleaning tick', 'coherency', 'complete',
         'conformance suite', 'control step', 'embedded runner', 'existence search',
         'held-out seeds', 'HIL', 'latched', 'lockstep, realtime', 'MCAP', 'node system',
         'plug-in', 'profile', 'QoS', 'recorder', 'screening study', 'sim time')


def shipped_text_files() -> list[Path]:
    """The pages, the parameter files and designs, and the code and tests a reader opens."""
    code = [path for folder in ('src', 'tests', 'bench', 'scripts', 'examples')
            for path in sorted((REPO / folder).rglob('*'))
            if path.suffix in ('.py', '.sh', '.yaml', '.md') and 'egg-info' not in str(path)]
    return [*PAGES, *sorted((REPO / 'ros_ws' / 'config').rglob('*.yaml')), *code]


def test_no_page_or_shipped_file_names_our_issues():
    files = [path for path in shipped_text_files() if path != Path(__file__).resolve()]
    found = [f'{path.relative_to(REPO)}:{number}: {line.strip()}'
             for path in files
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if OURS.search(line)]
    assert not found, '\n'.join(found)


def test_every_relative_link_of_the_pages_leads_to_a_file():
    broken = [f'{page.relative_to(REPO)}: {target}'
              for page in PAGES
              for target, _ in LINK.findall(page.read_text())
              if not (page.parent / target).exists()]
    assert not broken, '\n'.join(broken)


def test_the_glossary_defines_the_words_the_pages_lean_on_in_order():
    entries = re.findall(r'^\*\*([^*]+)\*\*', (REPO / 'docs' / 'glossary.md').read_text(),
                         flags=re.MULTILINE)
    assert entries == sorted(entries, key=str.lower)  # alphabetical: a reader scans for it
    missing = [term for term in TERMS if term not in entries]
    assert not missing, f'docs/glossary.md lacks {missing}'

"""The mistakes table: ordinary mistakes a user makes, each refused (or handled) with the
right exit status and a one-line message naming the key and the fix, and, where refused,
nothing written: every watched folder byte-identical before and after."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import cases_inputs
import cases_launch
import cases_places
import cases_run
import cases_study
from mistake import Mistake, folder_digest, run_mistake

TABLE: list[Mistake] = [*cases_run.CASES, *cases_launch.CASES, *cases_study.CASES,
                        *cases_inputs.CASES, *cases_places.CASES]


@pytest.mark.parametrize('mistake', TABLE, ids=[m.name for m in TABLE])
def test_mistake(mistake: Mistake, tmp_path: Path) -> None:
    if mistake.setup:
        mistake.setup(tmp_path)
    before = {name: folder_digest(tmp_path / name) for name in mistake.unchanged}
    done = run_mistake(mistake, tmp_path)
    said = done.stderr + done.stdout
    assert done.returncode == mistake.status, said[-2000:]
    assert re.search(mistake.pattern, said), said[-2000:]
    if mistake.status == 2:
        assert 'Traceback' not in said, said[-2000:]
    for name, digest in before.items():
        assert folder_digest(tmp_path / name) == digest, f'{name} changed'

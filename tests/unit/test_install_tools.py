"""tests/install-tools.sh (make firmware-tools, make browser-tools) on a copy of the browser
app: under CI=true a Foxglove build that cannot install fails naming the command and showing
its output's tail (a package.json npm cannot parse: what kept the browser tier from ever
running on a fresh machine); elsewhere it only says so, and the tests skip; an installed build
whose package.json and lock are unchanged is not installed again."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """A copy of the script and the browser app, as tests/ holds them."""
    (tmp_path / 'tests' / 'browser').mkdir(parents=True)
    shutil.copy2(TESTS / 'install-tools.sh', tmp_path / 'tests')
    shutil.copytree(TESTS / 'browser' / 'app', tmp_path / 'tests' / 'browser' / 'app')
    return tmp_path


def install(tree: Path, cache: Path, ci: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, CI=ci, FOXGLOVE_CACHE=str(cache))
    return subprocess.run([str(tree / 'tests' / 'install-tools.sh'), 'foxglove'], env=env,
                          capture_output=True, text=True, timeout=120)


def break_package_json(tree: Path) -> None:
    package = tree / 'tests' / 'browser' / 'app' / 'package.json'
    package.write_text(package.read_text().replace('"private": true,',
                                                   '"description": "see "the layout"",'))


@pytest.mark.skipif(shutil.which('npm') is None, reason='npm: make browser-tools installs it')
def test_under_ci_a_build_that_cannot_install_fails_naming_the_command(tree, tmp_path):
    break_package_json(tree)
    result = install(tree, tmp_path / 'cache', 'true')
    assert result.returncode == 1, result.stderr
    assert '`npm ci` of tests/browser/app/package.json and its lock' in result.stderr
    assert 'EJSONPARSE' in result.stderr  # the tail of npm's own output
    assert 'FAILED (CI=true' in result.stderr
    assert not (tmp_path / 'cache' / '.installed-key').exists()


@pytest.mark.skipif(shutil.which('npm') is None, reason='npm: make browser-tools installs it')
def test_elsewhere_it_only_says_so(tree, tmp_path):
    break_package_json(tree)
    result = install(tree, tmp_path / 'cache', '')
    assert result.returncode == 0
    assert 'EJSONPARSE' in result.stderr and 'the browser tests will skip' in result.stderr


def test_an_installed_build_of_the_same_package_json_and_lock_is_kept(tree, tmp_path):
    app = tree / 'tests' / 'browser' / 'app'
    cache = tmp_path / 'cache'
    bundle = cache / 'node_modules' / '@foxglove' / 'studio-base' / 'assets' / 'index.js'
    bundle.parent.mkdir(parents=True)
    bundle.write_text('')
    key = hashlib.sha256((app / 'package.json').read_bytes() +
                         (app / 'package-lock.json').read_bytes()).hexdigest()
    (cache / '.installed-key').write_text(key + '\n')
    result = install(tree, cache, 'true')
    assert (result.returncode, result.stdout, result.stderr) == (0, '', '')  # nothing to do
    # A change to either file is another build: this one is installed anew (and here fails).
    break_package_json(tree)
    assert install(tree, cache, 'true').returncode == 1

"""The package a researcher installs and cites: `pip install .` at the root gives mona-swarm
with the tested library versions, and the licence, citation and version agree."""

from __future__ import annotations

import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import yaml

from swarm_supervisor import __version__

REPO = Path(__file__).resolve().parents[2]
TEST_TOOLS = {'pytest', 'pytest-xdist', 'hypothesis', 'ruff', 'mypy', 'playwright'}


def pins(lines: list[str]) -> dict[str, str]:
    found = {}
    for line in lines:
        name, sep, version = line.partition('==')
        if sep:
            found[name.strip()] = version.strip()
    return found


def test_the_root_project_pins_what_requirements_pin() -> None:
    project = tomllib.loads((REPO / 'pyproject.toml').read_text())['project']
    required = pins([line for line in (REPO / 'requirements.txt').read_text().splitlines()
                     if not line.startswith('#')])
    for tool in TEST_TOOLS:
        required.pop(tool)
    assert pins(project['dependencies']) == required
    packages = {dep.split(' @ ')[0] for dep in project['dependencies'] if ' @ ' in dep}
    assert packages == {'mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor'}


def test_licence_citation_and_version_agree() -> None:
    assert 'Apache License' in (REPO / 'LICENSE').read_text()[:200]
    for setup in REPO.glob('src/*/setup.py'):
        text = setup.read_text()
        assert "license='Apache-2.0'" in text, setup
        assert f"version='{__version__}'" in text, setup
    citation = yaml.safe_load((REPO / 'CITATION.cff').read_text())
    assert citation['cff-version'] == '1.2.0'
    assert str(citation['version']) == __version__
    paper = citation['preferred-citation']
    assert paper['title'].startswith('Cooperative Pollution Source Localization')
    assert [a['family-names'] for a in paper['authors']][0] == 'Amjadi'
    assert f'## [{__version__}]' in (REPO / 'CHANGELOG.md').read_text()


def test_the_root_builds_the_mona_swarm_wheel(tmp_path: Path) -> None:
    """The metadata pip installs from the root: the name, the version, the four packages."""
    subprocess.run([sys.executable, '-m', 'pip', 'wheel', '--quiet', '--no-deps',
                    '--wheel-dir', str(tmp_path), str(REPO)], check=True, timeout=300)
    wheel, = tmp_path.glob('mona_swarm-*.whl')
    with zipfile.ZipFile(wheel) as archive:
        metadata = next(name for name in archive.namelist() if name.endswith('METADATA'))
        text = archive.read(metadata).decode()
    assert 'Name: mona-swarm' in text
    assert f'Version: {__version__}' in text
    for package in ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor'):
        normalised = package.replace('_', '-')  # as pip writes distribution names
        assert f'Requires-Dist: {normalised} @ file://{REPO}/src/{package}' in text

"""Every tracked JSON, YAML and TOML file parses (a file npm, pip, a node or Foxglove reads
and cannot parse breaks a tool far from the edit), with no key given twice in one mapping
(the parsers keep the last silently); and the browser app's package.json and its lock agree,
as `npm ci` demands before it installs anything."""

from __future__ import annotations

import json
import re
import subprocess
import tomllib
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]
APP = REPO / 'tests' / 'browser' / 'app'
SUFFIXES = {'.json': 'json', '.yaml': 'yaml', '.yml': 'yaml', '.cff': 'yaml', '.toml': 'toml'}


def tracked() -> list[str]:
    """The repository's tracked files of the kinds above (git ls-files)."""
    listed = subprocess.run(['git', 'ls-files', '-z'], cwd=REPO, capture_output=True,
                            check=True, timeout=60).stdout.decode().split('\0')
    return sorted(name for name in listed if Path(name).suffix in SUFFIXES)


def no_duplicates(pairs: list[tuple[str, object]]) -> dict:
    keys = [key for key, _ in pairs]
    repeated = sorted({key for key in keys if keys.count(key) > 1})
    if repeated:
        raise ValueError(f'keys given twice: {repeated}')
    return dict(pairs)


class UniqueKeyLoader(yaml.SafeLoader):
    """PyYAML's safe loader, refusing a key given twice in one mapping."""

    def construct_mapping(self, node, deep=False):
        keys = [self.construct_object(key, deep=deep) for key, _ in node.value]
        repeated = sorted({str(key) for key in keys if keys.count(key) > 1})
        if repeated:
            raise yaml.constructor.ConstructorError(
                None, None, f'keys given twice: {repeated}', node.start_mark)
        return super().construct_mapping(node, deep=deep)


UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                                UniqueKeyLoader.construct_mapping)


def parse(path: Path) -> object:
    text = path.read_text(encoding='utf-8')
    kind = SUFFIXES[path.suffix]
    if kind == 'json':
        return json.loads(text, object_pairs_hook=no_duplicates)
    if kind == 'toml':
        return tomllib.loads(text)  # TOML itself forbids a key given twice
    return list(yaml.load_all(text, Loader=UniqueKeyLoader))


def test_the_repository_tracks_each_kind():
    kinds = {SUFFIXES[Path(name).suffix] for name in tracked()}
    assert kinds == {'json', 'yaml', 'toml'}
    assert 'tests/browser/app/package.json' in tracked()


@pytest.mark.parametrize('name', tracked())
def test_a_tracked_file_parses(name):
    parse(REPO / name)


def test_a_broken_file_and_a_repeated_key_are_caught(tmp_path):
    broken = tmp_path / 'package.json'
    broken.write_text('{"description": "see "The layout"", "license": "MIT"}')
    with pytest.raises(json.JSONDecodeError):
        parse(broken)
    twice = tmp_path / 'params.yaml'
    twice.write_text('world:\n  seed: 1\n  seed: 2\n')
    with pytest.raises(yaml.YAMLError, match='seed'):
        parse(twice)
    repeated = tmp_path / 'layout.json'
    repeated.write_text('{"a": 1, "a": 2}')
    with pytest.raises(ValueError, match="'a'"):
        parse(repeated)


# --- the browser app: package.json and package-lock.json ---------------------------------

def version(text: str) -> tuple[int, int, int]:
    major, minor, patch = (int(part) for part in text.split('-')[0].split('.'))
    return major, minor, patch


def satisfies(locked: str, spec: str) -> bool:
    """Whether version ``locked`` satisfies npm range ``spec``: the forms these files use
    (an exact version, ^, ~, >=, <, and alternatives joined by ||)."""
    if '||' in spec:
        return any(satisfies(locked, part) for part in spec.split('||'))
    have = version(locked)
    for term in spec.split():
        found = re.fullmatch(r'(\^|~|>=|<|=)?v?(\d+\.\d+\.\d+)', term)
        if found is None:
            raise ValueError(f'range {spec!r}: teach satisfies() this form')
        operator, want = found.group(1) or '=', version(found.group(2))
        if operator == '=':
            ok = have == want
        elif operator == '>=':
            ok = have >= want
        elif operator == '<':
            ok = have < want
        elif operator == '~':
            ok = want <= have < (want[0], want[1] + 1, 0)
        elif want[0] > 0:  # ^1.2.3: below the next major
            ok = want <= have < (want[0] + 1, 0, 0)
        else:  # ^0.2.3: below the next minor
            ok = want <= have < (0, want[1] + 1, 0)
        if not ok:
            return False
    return True


def resolve(packages: dict, holder: str, name: str) -> str | None:
    """The lock's entry for dependency ``name`` of the package at ``holder``: the nearest
    node_modules folder up from it, as Node resolves a require."""
    folder = holder
    while True:
        candidate = f'{folder}/node_modules/{name}' if folder else f'node_modules/{name}'
        if candidate in packages:
            return candidate
        if not folder:
            return None
        folder = folder.rpartition('/node_modules/')[0] if '/node_modules/' in folder else ''


def lock_disagreements(manifest: dict, lock: dict) -> list[str]:
    """Why `npm ci` would refuse this package.json with this lock (empty: they agree)."""
    problems = []
    root = lock.get('packages', {}).get('', {})
    for key in ('name', 'version'):
        if manifest.get(key) != root.get(key):
            problems.append(f'{key}: package.json {manifest.get(key)!r}, lock {root.get(key)!r}')
    for kind in ('dependencies', 'devDependencies', 'optionalDependencies',
                 'peerDependencies'):
        if manifest.get(kind, {}) != root.get(kind, {}):
            problems.append(f'{kind}: package.json {manifest.get(kind, {})}, '
                            f'lock {root.get(kind, {})}')
    packages = lock['packages']
    for holder, entry in packages.items():
        for kind in ('dependencies', 'optionalDependencies'):
            for name, spec in entry.get(kind, {}).items():
                where = resolve(packages, holder, name)
                if where is None:
                    if kind == 'dependencies':
                        problems.append(f'{holder or "the app"} needs {name} {spec}: '
                                        'not in the lock')
                elif not satisfies(packages[where]['version'], spec):
                    problems.append(f'{holder or "the app"} needs {name} {spec}: '
                                    f'the lock has {packages[where]["version"]}')
    return problems


def test_the_browser_apps_package_json_and_lock_agree():
    manifest = json.loads((APP / 'package.json').read_text())
    lock = json.loads((APP / 'package-lock.json').read_text())
    assert lock['lockfileVersion'] >= 2  # its root package lists the dependencies
    assert lock_disagreements(manifest, lock) == []
    for entry in lock['packages'].values():  # npm ci installs what is pinned, checked
        assert entry == lock['packages'][''] or entry.get('integrity', '').startswith('sha512-')


def test_a_lock_out_of_step_with_package_json_is_caught():
    manifest = json.loads((APP / 'package.json').read_text())
    lock = json.loads((APP / 'package-lock.json').read_text())
    manifest['dependencies']['react'] = '18.2.0'
    assert lock_disagreements(manifest, lock) == [
        "dependencies: package.json {'@foxglove/studio-base': '1.48.0', 'react': '18.2.0', "
        "'react-dom': '17.0.2'}, lock {'@foxglove/studio-base': '1.48.0', 'react': '17.0.2', "
        "'react-dom': '17.0.2'}"]
    lock['packages']['']['dependencies']['react'] = '18.2.0'
    assert lock_disagreements(manifest, lock) == [
        'the app needs react 18.2.0: the lock has 17.0.2']
    lock['packages']['node_modules/scheduler']['version'] = '0.19.1'
    assert 'node_modules/react-dom needs scheduler ^0.20.2: the lock has 0.19.1' in \
        lock_disagreements(manifest, lock)


def test_npm_ranges():
    assert satisfies('17.0.2', '17.0.2') and not satisfies('17.0.3', '17.0.2')
    assert satisfies('1.4.0', '^1.1.0') and not satisfies('2.0.0', '^1.1.0')
    assert satisfies('0.20.2', '^0.20.2') and not satisfies('0.21.0', '^0.20.2')
    assert satisfies('4.0.0', '^3.0.0 || ^4.0.0') and not satisfies('5.0.0', '^3.0.0 || ^4.0.0')
    assert satisfies('1.2.9', '~1.2.3') and not satisfies('1.3.0', '~1.2.3')
    assert satisfies('2.5.0', '>=2.0.0 <3.0.0') and not satisfies('3.0.0', '>=2.0.0 <3.0.0')

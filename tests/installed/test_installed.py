"""The project as a user installs and extends it.

``pip install .`` (the repository root's pyproject.toml) into a fresh virtual environment, from
a copy of the repository's files (pip builds in the tree it is given): the root's
distribution and the four packages it names by path are built and installed (not editable),
and ``pip check`` finds every requirement met. The warm step then reaches every cached numba
kernel of the installed copies, on their empty cache (as docs/architecture.md tells a user
who installed without ``make venv`` to run it). Then, from a temporary folder outside the
repository and with nothing of the repository on the path, the recipes of docs/extending.md
exactly as the page has them: each file of ``my_swarm/`` (a metric, a controller kind, an
obstacle layout, the parameter file naming them, a claim) written from the page, each of its
``cd my_swarm`` command blocks run by bash. They run an episode with its bag, ``analyze``, a
study with the claim on the metric, and the node system.

The pinned libraries are not installed again (that took minutes): the fresh venv sees the
test's own venv's copies through a ``.pth`` file naming a folder of links to them, every
entry of its site-packages but the project's four packages, pip and the build tools; a second
line of that file does for the ROS wheels' libraries what their ``ros_wheels_bootstrapper``
does in the venv that holds them (it looks only under ``sys.prefix``). pip sees those
libraries as installed, so it resolves the root's pinned dependencies against them and
installs nothing from an index. The build backends come from a small wheelhouse outside the
checkout (``MONA_SWARM_WHEELHOUSE``, default ~/.cache/mona-swarm/backends), which ``pip
download`` fills once per machine.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
import tomllib
from pathlib import Path

import pytest

from swarm_supervisor.cli.command import COMMAND_MODULES

from harness import recipes

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
PAGE = REPO / 'docs' / 'extending.md'
WHEELHOUSE = Path(os.environ.get('MONA_SWARM_WHEELHOUSE',
                                 Path.home() / '.cache' / 'mona-swarm' / 'backends'))
#: The build backends: the root's (hatchling) and the four packages' (setuptools' legacy one).
BACKENDS = ('setuptools', 'wheel')
#: The project's distributions (what the fresh venv must install itself), and what it has of
#: its own: these top-level entries of this venv's site-packages are not linked into it.
PROJECT = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor', 'mona_swarm')
OWN = ('pip', 'setuptools', 'wheel', 'pkg_resources', '_distutils_hack', 'hatchling',
       '__pycache__')


def run(command: list[str], **options) -> subprocess.CompletedProcess:
    """A command that must succeed; its output is shown when it does not."""
    done = subprocess.run(command, capture_output=True, text=True, **options)
    assert done.returncode == 0, f'{command} exited {done.returncode}:\n{done.stdout[-3000:]}' \
                                 f'\n{done.stderr[-6000:]}'
    return done


def requirements() -> list[str]:
    """What the install needs from the wheelhouse: every build backend."""
    project = tomllib.loads((REPO / 'pyproject.toml').read_text())
    return sorted(project['build-system']['requires'] + list(BACKENDS))


def fill_wheelhouse() -> None:
    """Download the backends' wheels once (a marker file lists what is there)."""
    wanted = '\n'.join(requirements()) + '\n'
    marker = WHEELHOUSE / '.requirements'
    if marker.is_file() and marker.read_text() == wanted:
        return
    WHEELHOUSE.mkdir(parents=True, exist_ok=True)
    run([sys.executable, '-m', 'pip', 'download', '--quiet', '--dest', str(WHEELHOUSE),
         *requirements()], timeout=600)
    marker.write_text(wanted)


def copy_repository(to: Path) -> Path:
    """The repository's files (tracked, and new ones not ignored) copied to ``to``."""
    listed = run(['git', 'ls-files', '-z', '--cached', '--others', '--exclude-standard'],
                 cwd=REPO, timeout=60).stdout.split('\0')
    for name in filter(None, listed):
        source = REPO / name
        if source.is_file() or source.is_symlink():
            target = to / name
            target.parent.mkdir(parents=True, exist_ok=True)
            if source.is_symlink():
                target.symlink_to(os.readlink(source))
            else:
                shutil.copy2(source, target)
    return to


def _normal(entry: str) -> str:
    """A site-packages entry's distribution or module name, lower case, ``-`` as ``_``."""
    return re.split(r'[-.]', entry, maxsplit=1)[0].lower().replace('-', '_')


def link_libraries(venv: Path, links: Path) -> None:
    """Make this venv's libraries, less the project's and the fresh venv's own, importable
    in ``venv``: ``links`` gets a link to each, and a ``.pth`` file in ``venv``'s
    site-packages names it, then points the dynamic loader at the ROS wheels' libraries (as
    their ``ros_wheels_bootstrapper`` does: re-running Python once with LD_LIBRARY_PATH
    set)."""
    ours = Path(sysconfig.get_paths()['purelib'])
    links.mkdir()
    for entry in sorted(os.listdir(ours)):
        if entry.endswith('.pth') or entry.startswith('__editable__') \
                or _normal(entry) in PROJECT + OWN:
            continue
        (links / entry).symlink_to(ours / entry)
    libraries = [str(Path(sys.prefix) / 'lib'),
                 *sorted(str(p) for p in ours.glob('ros_*.libs') if p.is_dir())]
    bootstrap = (
        "import os, sys; os.environ.get('_ROS_WHEELS_BOOTSTRAP_COMPLETE') or os.execve("
        "sys.executable, sys.orig_argv, {**os.environ, '_ROS_WHEELS_BOOTSTRAP_COMPLETE': '1', "
        f"'LD_LIBRARY_PATH': os.pathsep.join([*{libraries!r}, *filter(None, os.environ.get("
        "'LD_LIBRARY_PATH', '').split(os.pathsep))])})")
    site = Path(run([str(venv / 'bin' / 'python'), '-c',
                     'import sysconfig; print(sysconfig.get_paths()["purelib"])'],
                    timeout=60).stdout.strip())
    (site / 'mona_swarm_test_libraries.pth').write_text(f'{links}\n{bootstrap}\n')


@pytest.fixture(scope='module')
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh virtual environment with the project ``pip install``ed: its bin folder."""
    started = time.monotonic()
    fill_wheelhouse()
    root = tmp_path_factory.mktemp('install')
    source = copy_repository(root / 'mona-swarm')
    venv = root / 'venv'
    run([sys.executable, '-m', 'venv', str(venv)], timeout=300)
    link_libraries(venv, root / 'libraries')
    python = str(venv / 'bin' / 'python')
    env = user_environment(venv / 'bin')
    local = ['--quiet', '--no-index', '--find-links', str(WHEELHOUSE)]
    run([python, '-m', 'pip', 'install', *local, *requirements()], cwd=root, env=env,
        timeout=600)
    run([python, '-m', 'pip', 'install', *local, '--no-build-isolation', str(source)],
        cwd=root, env=env, timeout=1800)
    run([python, '-m', 'pip', 'check'], cwd=root, env=env, timeout=300)
    print(f'installed in {time.monotonic() - started:.0f} s')
    return venv / 'bin'


def user_environment(bin_dir: Path) -> dict[str, str]:
    """A shell of a user who activated the venv: nothing of the repository on any path, and
    nothing of this venv's ROS bootstrap (the fresh venv does its own)."""
    env = {key: value for key, value in os.environ.items()
           if key not in ('PYTHONPATH', 'VIRTUAL_ENV', 'MONA_SWARM_METRICS',
                          '_ROS_WHEELS_BOOTSTRAP_COMPLETE')
           and not key.startswith(('PYTEST', 'AMENT'))}
    env['PATH'] = os.pathsep.join([str(bin_dir), *[p for p in env.get('PATH', '').split(
        os.pathsep) if p and not p.startswith(str(REPO))]])
    loader = [p for p in env.pop('LD_LIBRARY_PATH', '').split(os.pathsep)
              if p and not p.startswith((str(REPO), sys.prefix))]
    if loader:
        env['LD_LIBRARY_PATH'] = os.pathsep.join(loader)
    env['VIRTUAL_ENV'] = str(bin_dir.parent)
    return env


def test_the_recipes_parse():
    """The page has the user's folder and commands that use every file of it."""
    files, commands = recipes(PAGE.read_text())
    assert {'my_swarm/params.yaml', 'my_swarm/under_robots.py', 'my_swarm/shy.py',
            'my_swarm/ring.py', 'my_swarm/claims.yaml'} <= set(files)
    script = '\n'.join(commands)
    for needed in ('mona-swarm run', 'mona-swarm study', 'mona-swarm analyze',
                   'mona-swarm launch', '--claims claims.yaml'):
        assert needed in script


# In a fresh process on the installed copies' empty cache: import every module of the
# packages (a kernel in a module that warm never imports counts too), then warm, then report
# each cached kernel's compiled signatures.
WARM_PROBE = """
import importlib, json, pkgutil
from swarm_supervisor.engine import warm
for package in warm.PACKAGES:
    root = importlib.import_module(package)
    for info in pkgutil.walk_packages(root.__path__, package + '.'):
        if not info.name.endswith('__main__'):
            importlib.import_module(info.name)
before = {name: len(kernel.signatures) for name, kernel in warm.cached_kernels()}
warmed = warm.warm_kernels()
after = {name: len(kernel.signatures) for name, kernel in warm.cached_kernels()}
print(json.dumps({'before': before, 'after': after, 'kernels': warmed.kernels}))
"""


def test_warm_compiles_every_cached_kernel(installed: Path, tmp_path: Path):
    """The warm step (swarm_supervisor.engine.warm) reaches every cached numba kernel of the
    four packages: run on an empty cache, each ``cache=True`` kernel of any module compiles
    and writes its cache index. A new cached kernel that it does not reach fails here, so the
    kernel would not be compiled in parallel by the processes started after ``make venv``,
    the suite's controller or a user warmed the cache (numba/numba#4807). (It runs first on
    the fresh venv, so the recipes below find the cache warm, as a user's would be.)"""
    env = user_environment(installed)
    site = installed.parent / 'lib' / f'python{sys.version_info[0]}.{sys.version_info[1]}' \
        / 'site-packages'
    assert not list(site.rglob('*.nbi')), 'the installed copies have a numba cache already'
    # A hang's bound: the compilation is about 40 s of CPU, but took over 10 min of wall
    # time on 2 cores loaded 10 times over.
    done = run([str(installed / 'python'), '-c', WARM_PROBE], cwd=tmp_path, env=env,
               timeout=1800)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    before, after = report['before'], report['after']
    # The probe found the kernels (34 when this was written), none compiled by importing.
    assert len(before) >= 30 and not any(before.values()), before
    # The kernels it found are the source's: one per ``cache=True`` in the packages (an
    # independent count, so a kernel the discovery misses fails here).
    source = sum(len(re.findall(r'^\s*@.*cache=True', path.read_text(), re.MULTILINE))
                 for path in (REPO / 'src').rglob('*.py'))
    assert report['kernels'] == len(after) == source
    missed = sorted(name for name, signatures in after.items() if not signatures)
    assert not missed, ('cached kernels the warm step does not compile (add the feature '
                        f'that reaches them to swarm_supervisor.engine.warm): {missed}')
    # Each wrote its index beside its installed source: __pycache__/<module>.<function>-
    # <line>.py<version>.nbi.
    indexes = {path.name.split('-')[0] for path in site.rglob('*.nbi')}
    unwritten = sorted(name for name in after
                       if '.'.join(name.split('.')[-2:]) not in indexes)
    assert not unwritten, f'cached kernels without a cache index: {unwritten}'


def test_the_installed_copies_run(installed: Path, tmp_path: Path):
    """The console script is the fresh venv's, and the modules it imports are the copies
    pip installed there, not the repository's; ROS loads."""
    env = user_environment(installed)
    assert shutil.which('mona-swarm', path=env['PATH']) == str(installed / 'mona-swarm')
    venv = installed.parent.resolve()
    done = run([str(installed / 'python'), '-c',
                'import json, rclpy, mona_controller, swarm_world, swarm_metrics, '
                'swarm_supervisor, sys; print(json.dumps([sys.prefix] + [m.__file__ for m in '
                '(mona_controller, swarm_world, swarm_metrics, swarm_supervisor)]))'],
               cwd=tmp_path, env=env, timeout=120)
    prefix, *files = json.loads(done.stdout)
    assert Path(prefix).resolve() == venv
    for file in files:
        assert Path(file).resolve().is_relative_to(venv), file
    script = (installed / 'mona-swarm').read_text().split('\n', 1)[0]
    assert script == f'#!{installed / "python"}', script


def test_an_installed_package_runs_the_recipes_from_a_folder_of_ones_own(
        installed: Path, tmp_path: Path):
    files, commands = recipes(PAGE.read_text())
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    env = user_environment(installed)
    # Every command's help, from anywhere: each subcommand's module imports.
    for names in COMMAND_MODULES.values():
        for command in names:
            run(['mona-swarm', command, '--help'], cwd=tmp_path, env=env, timeout=120)
    timings = []
    for script in commands:
        started = time.monotonic()
        run(['bash', '-euo', 'pipefail', '-c', script], cwd=tmp_path, env=env, timeout=1800)
        timings.append(round(time.monotonic() - started))
    print('recipe blocks took', timings, 's')

    out = tmp_path / 'my_swarm' / 'results'
    plugins = {Path(p['path']).name: p for p in
               json.loads((out / 'mine' / 'episode.json').read_text())['plugins']}
    assert set(plugins) == {'under_robots.py', 'shy.py', 'ring.py'}
    # The controller kind: two episodes stepped together, a study factor, the node system.
    for seed in (1, 2):
        kind = json.loads((out / 'shy' / f's{seed}' / 'episode.json').read_text())
        assert kind['parameters']['controller']['kind'] == 'shy'
    # The metric: a column of the episode, of the analysis and of the study's table, a
    # figure, and the claim on it checked in the report.
    for csv in (out / 'mine' / 'metrics.csv', out / 'again' / 'metrics.csv',
                out / 'study' / 'all_metrics.csv'):
        assert 'cue_under_robots' in csv.read_text().split('\n', 1)[0].split(','), csv
    assert (out / 'study' / 'fig_metric_cue_under_robots.png').stat().st_size > 10_000
    report = (out / 'study' / 'report.md').read_text()
    assert re.search(r'\| `robots_stand_on_the_cue` \|.*\| (holds|\*\*does not hold\*\*) \|',
                     report)
    assert plugins['under_robots.py']['sha256'] in report
    # The layout and the kind: study factors; the node system's nodes ran both.
    header = (out / 'study' / 'all_metrics.csv').read_text().split('\n', 1)[0].split(',')
    assert {'controller.kind', 'world.layout'} <= set(header)
    run_record = json.loads((out / 'ros' / 'run.json').read_text())
    assert run_record['parameters']['world']['layout'] == 'ring'
    assert run_record['parameters']['controller']['kind'] == 'shy'
    assert {Path(p['path']).name for p in run_record['plugins']} == set(plugins)
    analysed = json.loads((out / 'ros_again' / 'episode.json').read_text())
    assert analysed['complete'] and analysed['plugins'] == run_record['plugins']

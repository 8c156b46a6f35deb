"""mypy's configuration is folder rules, not lists of files: every module of the four packages
but the ROS adapters (a ``ros`` folder), and ``--strict``'s every flag on the pure cores."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor')
#: The pure cores, strictly: the three lower packages and swarm_supervisor's engine.
STRICT = ['mona_controller.*', 'swarm_world.*', 'swarm_metrics.*', 'swarm_supervisor.engine.*']
#: --strict's flags that mypy takes only for the whole run (set there, or not needed).
GLOBAL_ONLY = {'warn_unused_configs', 'warn_redundant_casts'}

CONFIG = tomllib.loads((REPO / 'pyproject.toml').read_text())['tool']['mypy']


def strict_flags() -> set[str]:
    """The flags ``mypy --strict`` enables, as configuration keys, from this mypy's help."""
    text = subprocess.run([sys.executable, '-m', 'mypy', '--help'], capture_output=True,
                          text=True, check=True).stdout
    listed = text.split('enables the following flags:', 1)[1].split('\n  --', 1)[0]
    flags = re.findall(r'--([a-z-]+)', ' '.join(listed.split()).replace('- ', '-'))
    assert len(flags) > 8, listed
    return {('implicit_reexport' if flag == 'no-implicit-reexport' else flag.replace('-', '_'))
            for flag in flags}


def test_every_package_is_checked_but_its_ros_folder():
    assert CONFIG['files'] == [f'src/{package}/{package}' for package in PACKAGES]
    assert CONFIG['exclude'] == ['/ros/']


def test_the_pure_cores_get_every_strict_flag():
    [override] = [o for o in CONFIG.get('overrides', []) if o['module'] == STRICT]
    expected = strict_flags() - GLOBAL_ONLY
    wanted = {flag: False if flag == 'implicit_reexport' else True for flag in expected}
    assert {flag: override.get(flag) for flag in expected} == wanted
    assert CONFIG['warn_redundant_casts'] is True
    others = [o for o in CONFIG.get('overrides', []) if o is not override]
    assert not others, f'no module is left out or relaxed by a list of its own: {others}'

"""The warm step (swarm_supervisor.engine.warm) reaches every cached numba kernel of the four
packages: run on an empty cache, each ``cache=True`` kernel of any module compiles and writes
its cache index. A new cached kernel that it does not reach fails here, so the kernel would
not be compiled in parallel by the processes started after ``make venv``, the suite's
controller or the launcher warmed the cache (numba/numba#4807)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

# In a fresh process with an empty cache: import every module of the packages (a kernel in a
# module that warm never imports counts too), then warm, then report each cached kernel's
# compiled signatures.
PROBE = """
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


@pytest.mark.slow
def test_warm_compiles_every_cached_kernel(tmp_path: Path) -> None:
    cache = tmp_path / 'numba-cache'
    env = {**os.environ, 'NUMBA_CACHE_DIR': str(cache)}
    # A hang's bound: the compilation is about 40 s of CPU, but took over 10 min of wall
    # time on 2 cores loaded 10 times over.
    done = subprocess.run([sys.executable, '-c', PROBE], env=env, capture_output=True,
                          text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    before, after = report['before'], report['after']
    # The probe found the kernels (34 when this was written), none compiled by importing.
    assert len(before) >= 30 and not any(before.values()), before
    # The kernels it found are the source's: one per ``cache=True`` in the packages (an
    # independent count, so a kernel the discovery misses fails here).
    source = sum(len(re.findall(r'^\s*@.*cache=True', path.read_text(), re.MULTILINE))
                 for path in (Path(__file__).resolve().parents[2] / 'src').rglob('*.py'))
    assert report['kernels'] == len(after) == source
    missed = sorted(name for name, signatures in after.items() if not signatures)
    assert not missed, ('cached kernels the warm step does not compile (add the feature '
                        f'that reaches them to swarm_supervisor.engine.warm): {missed}')
    # Each wrote its index: <module>.<function>-<line>.py<version>.nbi in the cache.
    indexes = {path.name.split('-')[0] for path in cache.rglob('*.nbi')}
    unwritten = sorted(name for name in after
                       if '.'.join(name.split('.')[-2:]) not in indexes)
    assert not unwritten, f'cached kernels without a cache index: {unwritten}'

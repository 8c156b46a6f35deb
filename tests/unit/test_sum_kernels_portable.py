"""The metrics' sum kernels give the same bits whatever CPU numba compiles them for.

They add in an order fixed in the source (no fastmath 'reassoc'), so a per-source column or a
large swarm's coherency cannot differ between an AVX-512 machine and an older one (it did:
the golden digests recorded on one machine failed on another). Here the kernels run in a
subprocess compiled for the architecture's baseline CPU (plain x86-64: SSE2) and must match
this process bit for bit.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import numpy as np

from swarm_metrics import metrics

SCRIPT = """
import sys
import numpy as np
from swarm_metrics import metrics
rng = np.random.default_rng(7)
cue = (rng.random((97, 131)) * 255).astype(np.float32)
xy = rng.random((1234, 2)) * 2.85
totals = metrics.region_totals(cue, 0.02, np.array([0.5, 1.9, 2.2]), np.array([0.4, 1.0, 1.7]))
rows = metrics._row_distance_sums(np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1]))
sys.stdout.write(totals.tobytes().hex() + ' ' + rows.tobytes().hex())
"""


#: LLVM's baseline CPU of this machine's architecture (plain x86-64: SSE2 only).
BASELINE = {'x86_64': 'x86-64', 'AMD64': 'x86-64'}.get(platform.machine(), 'generic')


def test_sum_kernels_equal_on_a_baseline_cpu_target(tmp_path):
    here = subprocess.run([sys.executable, '-c', SCRIPT], capture_output=True, text=True,
                          check=True).stdout
    env = dict(os.environ, NUMBA_CPU_NAME=BASELINE, NUMBA_CACHE_DIR=str(tmp_path))
    baseline = subprocess.run([sys.executable, '-c', SCRIPT], capture_output=True, text=True,
                              check=True, env=env).stdout
    assert baseline == here


def test_ordered_sum_adds_in_the_documented_order():
    # Four lanes over the first eight terms (lane = k % 4), the lanes in pairs, then the tail;
    # large and small terms make any other order give another answer.
    terms = np.array([1e16, 1.0, -1e16, 1.0, 3.0, 1.0, 2.0, 1.0, 5.0])
    lanes = [terms[0] + terms[4], terms[1] + terms[5], terms[2] + terms[6], terms[3] + terms[7]]
    expected = ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + terms[8]
    assert metrics._ordered_sum(terms, len(terms)) == expected
    assert expected != sum(terms.tolist())  # the order matters for these terms

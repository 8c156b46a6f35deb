"""A bag writer killed with SIGKILL: what it loses is bounded, and the rest is recovered."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from swarm_metrics.bag_reader import TruncatedBagError, read_episode_bag
from swarm_metrics.recover import recover_bag
from swarm_supervisor import cli

CHUNK_PERIOD = 1.0  # s of log time per chunk: the most a SIGKILL may lose
STEP_NS = 100_000_000  # the stream writes one pose and one metric every 0.1 s


def kill_writer_midstream(bag: Path, after_ns: int) -> int:
    """Start a writer process, SIGKILL it once it wrote past ``after_ns``; return the log time
    of the last message it reported as written."""
    process = subprocess.Popen(
        [sys.executable, str(Path(__file__).with_name('bagtools.py')), str(bag),
         str(CHUNK_PERIOD)], stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        for line in process.stdout:
            if int(line) >= after_ns:
                os.killpg(process.pid, signal.SIGKILL)
                break
        process.wait(30)
        rest = process.stdout.read().split()  # lines printed before it died
        return int(rest[-1]) if rest else int(line)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        process.stdout.close()


@pytest.mark.parametrize('after_s', [0.05, 20.0])
def test_sigkilled_writer_loses_at_most_one_chunk(tmp_path, after_s):
    bag = tmp_path / 'bag'
    written = kill_writer_midstream(bag, round(after_s * 1e9))
    assert not (bag / 'metadata.yaml').exists()  # the writer never closed it
    with pytest.raises(TruncatedBagError, match='recover'):
        read_episode_bag(bag)

    report = recover_bag(bag)
    assert report.target == tmp_path / 'bag_recovered' and not report.was_complete
    recovered = read_episode_bag(report.target)
    assert recovered.report.complete
    assert recovered.seed == 1  # the announcement was flushed before anything else
    assert json.loads(recovered.custom['mona_swarm.recovered'])['messages'] == report.messages
    lost_ns = written - recovered.report.last_ns
    assert 0 <= lost_ns <= CHUNK_PERIOD * 1e9 + STEP_NS, (written, recovered.report.last_ns)
    # every message up to the last recovered one is there: 2 per step, 1 announcement
    steps = recovered.report.last_ns // STEP_NS
    assert report.messages == 2 * steps + 1


def test_analyze_recovers_a_crashed_bag(tmp_path, capsys):
    bag = tmp_path / 'episode_0' / 'bag'
    written = kill_writer_midstream(bag, 15 * 10**9)
    # recovered, but the episode never finished: incomplete, exit 1 (docs/bags.md)
    assert cli.main(['analyze', str(bag)]) == 1
    err = capsys.readouterr().err
    assert 'was cut short' in err and 'fails the finished, samples' in err
    analysis = tmp_path / 'episode_0' / 'bag.analysis'  # beside the bag, never into its folder
    assert not analysis.exists()
    assert cli.main(['analyze', str(bag), '--allow-incomplete']) == 0
    out = capsys.readouterr().out
    assert 'INCOMPLETE' in out and 'recovered copy' in out
    record = json.loads((analysis / 'episode.json').read_text())
    assert record['recovered'] and not record['complete'] and record['seed'] == 1
    assert 'finished' in [finding['check'] for finding in record['completeness']]
    assert written / 1e9 - CHUNK_PERIOD - 1.0 <= record['sim_time_covered'] <= written / 1e9

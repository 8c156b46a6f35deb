"""Damaged bags: every truncation and bit flip gives a clear BagError or a correct result.

A seeded loop over a real episode bag (not hypothesis: the cases are cheap and a fixed set
keeps the run time bounded and reproducible).
"""

from __future__ import annotations

import random
import shutil

import pytest

from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.reader import read_episode_bag
from swarm_metrics.bags.recover import recover_bag
from swarm_metrics.bags.scan import BagError, TruncatedBagError
from swarm_supervisor import cli
from swarm_supervisor.cli.bags import checked_mcap
from swarm_supervisor.config import load_config

from bagtools import embedded_episode_bag

CONFIG = load_config().replace(episode={'population': 8, 'duration': 12.0, 'seed': 9})
TRUNCATIONS = 50
FLIPS = 200


@pytest.fixture(scope='module')
def original(tmp_path_factory):
    """(the .mcap bytes, the embedded rows) of a small episode with several chunks."""
    path = tmp_path_factory.mktemp('fuzz') / 'bag'
    rows = embedded_episode_bag(path, CONFIG, map_period=4.0, chunk_period=1.5)
    return (path / 'bag.mcap').read_bytes(), rows


def damaged(tmp_path, data: bytes):
    """A bag directory (no metadata.yaml, as after a crash) holding ``data``."""
    bag = tmp_path / 'case'
    shutil.rmtree(bag, ignore_errors=True)
    shutil.rmtree(tmp_path / 'case_recovered', ignore_errors=True)
    bag.mkdir()
    (bag / 'case.mcap').write_bytes(data)
    return bag


def test_truncated_bags_are_reported_and_recovered(original, tmp_path):
    data, rows = original
    rng = random.Random(1)
    offsets = sorted({0, 7, 8, 30, len(data) - 1} | {rng.randrange(len(data))
                                                     for _ in range(TRUNCATIONS)})
    recovered = 0
    for offset in offsets:
        bag = damaged(tmp_path, data[:offset])
        with pytest.raises(BagError) as caught:
            read_episode_bag(bag)
        assert str(bag) in str(caught.value)
        with pytest.raises(BagError):
            checked_mcap(bag)  # what replay reads first
        if not isinstance(caught.value, TruncatedBagError):
            assert 'nothing is readable' in str(caught.value) and offset < 40
            continue
        try:
            report = recover_bag(bag)
        except BagError as error:  # cut before the first chunk ended
            assert 'nothing to recover' in str(error)
            continue
        result = recompute(read_episode_bag(report.target))
        assert result.rows == rows[:len(result.rows)]  # a prefix of the true metrics
        assert report.good_bytes <= offset
        recovered += 1
    assert recovered > TRUNCATIONS // 2


def test_flipped_bits_never_give_wrong_metrics(original, tmp_path):
    data, rows = original
    rng = random.Random(2)
    outcomes = {'error': 0, 'correct': 0}
    for case in range(FLIPS):
        corrupt = bytearray(data)
        position = rng.randrange(len(data))
        if case % 5:
            corrupt[position] ^= 1 << rng.randrange(8)
        else:
            corrupt[position] = rng.randrange(256)
        bag = damaged(tmp_path, bytes(corrupt))
        try:
            result = recompute(read_episode_bag(bag))
        except BagError as error:
            assert str(error), position
            outcomes['error'] += 1
            continue
        # undetected damage may only hit bytes the data do not depend on
        assert result.rows == rows, f'flip at byte {position} changed the metrics'
        outcomes['correct'] += 1
    assert outcomes['error'] > FLIPS // 2, outcomes
    print(f'bit flips: {outcomes}')


def test_bad_bags_exit_2_with_one_paragraph(original, tmp_path, capsys):
    data, _ = original
    corrupt = bytearray(data)
    corrupt[len(data) // 2] ^= 0x10  # inside a chunk: its CRC fails
    bag = damaged(tmp_path, bytes(corrupt))
    for command in (['analyze', str(bag)], ['replay', str(bag)]):
        assert cli.main(command) == 2
        err = capsys.readouterr().err
        assert 'damaged' in err and 'Traceback' not in err and err.count('\n') == 1
    # recover skips the damaged chunk, keeps the rest and says what was lost (exit 1)
    assert cli.main(['recover', str(bag)]) == 1
    out = capsys.readouterr().out
    assert 'LOST' in out and 'in 1 chunk: the damaged chunk at byte' in out

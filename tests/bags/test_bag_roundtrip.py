"""Episode bags: written, read back by rosbags and by the mcap library, analysed."""

from __future__ import annotations

import json

import pytest
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader

from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.reader import find_mcap, read_episode_bag
from swarm_metrics.bags.scan import BagError
from swarm_metrics.bags.writer import EpisodeBagWriter
from swarm_supervisor import cli
from swarm_supervisor.config import load_config
from swarm_supervisor.outputs.episode_folder import read_metrics_csv, write_metrics_csv
from swarm_world.messages.cdr import TYPESTORE

from bagtools import TOPICS, embedded_episode_bag, string_cdr

CONFIG = load_config().replace(episode={'population': 12, 'duration': 20.0, 'seed': 5})


@pytest.fixture(scope='module')
def episode(tmp_path_factory):
    """(bag directory, the embedded runner's rows) of one short episode."""
    path = tmp_path_factory.mktemp('episode') / 'bag'
    return path, embedded_episode_bag(path, CONFIG, chunk_period=2.0)


def test_bag_opens_with_rosbags_and_mcap(episode):
    path, rows = episode
    assert find_mcap(path) == path / 'bag.mcap'  # rosbags' <dir>/<dir>.mcap
    with Reader(path) as reader:
        assert set(reader.topics) == set(TOPICS)
        messages = list(reader.messages())
        first = [m for c, _, m in messages if c.topic == '/episode'][0]
        assert json.loads(TYPESTORE.deserialize_cdr(first, 'std_msgs/msg/String').data)[
            'seed'] == 5
        assert reader.storage.metadata.custom['mona_swarm.seed'] == '5'
        count = len(messages)
    with open(path / 'bag.mcap', 'rb') as handle:
        mcap = make_reader(handle, validate_crcs=True)  # our chunks carry CRCs
        assert sum(1 for _ in mcap.iter_messages()) == count
        summary = mcap.get_summary()
        assert len(summary.chunk_indexes) >= 7  # a chunk per 2-3 s of sim time
        assert {c.compression for c in summary.chunk_indexes} == {'zstd'}
    assert len(rows) == 21 and count > 4 * len(rows)


@pytest.mark.parametrize('cleaning', ['monotone', 'literal'])
def test_recomputed_metrics_equal_the_embedded_runner(tmp_path, cleaning):
    config = CONFIG.replace(world={'cleaning': cleaning}, metrics={'sample_period': 0.5})
    rows = embedded_episode_bag(tmp_path / 'bag', config, all_poses=True)
    result = recompute(read_episode_bag(tmp_path / 'bag'))
    assert result.rows == rows  # exactly, from the initial disc + the cleaning events
    assert result.online_max_diff == 0.0 and result.online_rows == len(rows)
    assert result.cue_maps_checked == 11 and result.cue_map_max_diff == 0
    assert rows[-1]['mean_cue'] < rows[0]['mean_cue']  # something was cleaned


def test_missing_metadata_yaml_is_tolerated(episode, tmp_path):
    path, rows = episode
    copy = tmp_path / 'bag'
    copy.mkdir()
    (copy / 'bag.mcap').write_bytes((path / 'bag.mcap').read_bytes())  # no metadata.yaml
    bag = read_episode_bag(copy)
    assert bag.seed == 5 and bag.custom['mona_swarm.seed'] == '5'  # the MCAP's own copy
    assert recompute(bag).rows == rows
    with Reader(copy / 'bag.mcap') as reader:
        assert reader.message_count == bag.report.messages


def test_writer_closes_the_bag_when_its_block_raises(tmp_path):
    with pytest.raises(RuntimeError), EpisodeBagWriter(tmp_path / 'bag') as bag:
        bag.add_topic('/episode', 'std_msgs/msg/String')
        bag.write('/episode', 5, string_cdr('{"seed": 1}'))
        raise RuntimeError('a node failing mid-episode')
    assert (tmp_path / 'bag' / 'metadata.yaml').exists()
    assert read_episode_bag(tmp_path / 'bag').report.complete


def test_analyze_writes_what_run_writes(episode, tmp_path, capsys):
    path, rows = episode
    assert cli.main(['analyze', str(path), '--out', str(tmp_path / 'analysis')]) == 0
    write_metrics_csv(rows, tmp_path / 'embedded.csv')
    assert (tmp_path / 'analysis' / 'metrics.csv').read_bytes() == \
        (tmp_path / 'embedded.csv').read_bytes()
    record = json.loads((tmp_path / 'analysis' / 'episode.json').read_text())
    assert record['seed'] == 5 and record['runner'] == 'ros' and record['complete']
    assert record['parameters'] == CONFIG.to_dict()
    assert record['online_metrics']['max_abs_diff'] == 0.0
    assert (tmp_path / 'analysis' / 'snapshots.npz').exists()
    assert 'online metrics agree to 0' in capsys.readouterr().out
    assert read_metrics_csv(tmp_path / 'analysis' / 'metrics.csv')['t'][-1] == 20.0


def test_not_a_bag_is_a_clear_error(tmp_path, capsys):
    (tmp_path / 'x.mcap').write_bytes(b'not an mcap file at all')
    with pytest.raises(BagError, match='not an MCAP file'):
        read_episode_bag(tmp_path / 'x.mcap')
    assert cli.main(['analyze', str(tmp_path / 'x.mcap'), str(tmp_path / 'missing')]) == 2
    err = capsys.readouterr().err
    assert 'not an MCAP file' in err and 'does not exist' in err and 'Traceback' not in err

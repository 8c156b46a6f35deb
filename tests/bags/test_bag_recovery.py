"""A bag writer killed with SIGKILL: what it loses is bounded, and the rest is recovered."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from swarm_metrics.bags.reader import read_episode_bag
from swarm_metrics.bags.recover import recover_bag
from swarm_metrics.bags.scan import TruncatedBagError
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


@pytest.fixture(scope='module')
def embedded_bag(tmp_path_factory) -> Path:
    """A real bag of a short embedded episode (`mona-swarm run --bag`)."""
    out = tmp_path_factory.mktemp('run') / 'run'
    assert cli.main(['run', '--population', '3', '--duration', '20', '--bag',
                     '--out', str(out)]) == 0
    return out / 'bag'


def chunk_contents(mcap: Path) -> tuple[list, int]:
    """The summary's chunk index entries, each with the messages its chunk really holds
    (counted by decompressing the chunk with the mcap library), and the total count."""
    import io

    from mcap.data_stream import ReadDataStream
    from mcap.reader import make_reader
    from mcap.records import Chunk, Message
    from mcap.stream_reader import breakup_chunk

    data = mcap.read_bytes()
    with open(mcap, 'rb') as handle:
        summary = make_reader(handle).get_summary()
    entries = []
    for entry in summary.chunk_indexes:
        body = data[entry.chunk_start_offset + 9:entry.chunk_start_offset + entry.chunk_length]
        chunk = Chunk.read(ReadDataStream(io.BytesIO(body)))
        held = sum(isinstance(r, Message) for r in breakup_chunk(chunk, validate_crc=True))
        entries.append((entry, held))
    return entries, summary.statistics.message_count


def test_recover_reports_exactly_what_a_damaged_chunk_held(embedded_bag, tmp_path, capsys):
    entries, total = chunk_contents(embedded_bag / 'bag.mcap')
    entry, held = max(entries, key=lambda pair: pair[1])  # the fullest chunk
    assert held > 0 and len(entries) >= 3
    bag = tmp_path / 'damaged'
    shutil.copytree(embedded_bag, bag)
    data = bytearray((bag / 'bag.mcap').read_bytes())
    data[entry.chunk_start_offset + entry.chunk_length // 2] ^= 0x10  # its CRC fails
    (bag / 'damaged.mcap').write_bytes(bytes(data))
    (bag / 'bag.mcap').unlink()

    assert cli.main(['recover', str(bag), '--out', str(tmp_path / 'recovered')]) == 1
    said = capsys.readouterr().out
    start, end = entry.message_start_time / 1e9, entry.message_end_time / 1e9
    assert (f"LOST {held} messages of the {total} the source's summary counts in 1 chunk: "
            f'the damaged chunk at byte {entry.chunk_start_offset}: {held} messages logged '
            f't = {start:.3f} to {end:.3f} s') in said, said
    record = json.loads(read_episode_bag(tmp_path / 'recovered').custom[
        'mona_swarm.recovered'])
    assert record['lost_messages'] == held == total - record['messages']
    (lost,) = record['lost_chunks']
    assert (lost['messages'], lost['start_ns'], lost['end_ns']) == (
        held, entry.message_start_time, entry.message_end_time)


def test_without_a_summary_a_damaged_chunk_is_counted_from_its_own_index(embedded_bag,
                                                                       tmp_path):
    """A bag without its summary (no chunk index): the chunk's header and the message index
    records after it give the same count and span."""
    entries, _ = chunk_contents(embedded_bag / 'bag.mcap')
    entry, held = max(entries, key=lambda pair: pair[1])
    data = bytearray((embedded_bag / 'bag.mcap').read_bytes())
    footer = data[-8 - 29:-8]  # opcode, length, summary_start, ...
    data = data[:int.from_bytes(footer[9:17], 'little')]  # up to the summary: DataEnd kept
    data[entry.chunk_start_offset + entry.chunk_length // 2] ^= 0x10
    source = tmp_path / 'cut' / 'cut.mcap'
    source.parent.mkdir()
    source.write_bytes(bytes(data))
    report = recover_bag(source)
    assert report.anything_lost and report.indexed_messages is None
    assert [(c.why, c.messages, c.start_ns, c.end_ns) for c in report.lost] == [
        ('damaged', held, entry.message_start_time, entry.message_end_time)]


def test_a_damaged_chunk_that_defined_channels_loses_only_its_own_messages(embedded_bag,
                                                                           tmp_path):
    """rosbags writes a channel's definition into the chunk of its first message; with the
    summary's copy of the channels the chunks after a damaged one are still read."""
    entries, total = chunk_contents(embedded_bag / 'bag.mcap')
    entry, held = entries[1]  # the first chunk after the announcement's: most channels
    data = bytearray((embedded_bag / 'bag.mcap').read_bytes())
    data[entry.chunk_start_offset + entry.chunk_length // 2] ^= 0x10
    source = tmp_path / 'd' / 'd.mcap'
    source.parent.mkdir()
    source.write_bytes(bytes(data))
    report = recover_bag(source)
    assert [(c.why, c.messages) for c in report.lost] == [('damaged', held)]
    assert report.messages == total - held


def test_recover_of_a_whole_bag_loses_nothing_and_exits_0(embedded_bag, tmp_path, capsys):
    assert cli.main(['recover', str(embedded_bag), '--out', str(tmp_path / 'copy')]) == 0
    assert 'nothing was lost' in capsys.readouterr().out


def test_a_chunk_cut_off_by_the_end_of_the_file_is_reported_with_its_span(embedded_bag,
                                                                          tmp_path, capsys):
    """A file that ends inside a chunk: the chunk's header gives its span, its count is
    unknown (its message index comes after it), and recover exits 1."""
    entries, _ = chunk_contents(embedded_bag / 'bag.mcap')
    entry, _ = max(entries, key=lambda pair: pair[1])
    source = tmp_path / 'cut' / 'cut.mcap'
    source.parent.mkdir()
    source.write_bytes((embedded_bag / 'bag.mcap').read_bytes()[
        :entry.chunk_start_offset + entry.chunk_length // 2])
    assert cli.main(['recover', str(source)]) == 1
    said = capsys.readouterr().out
    assert (f'LOST an unknown number of messages in 1 chunk: the cut-off chunk at byte '
            f'{entry.chunk_start_offset}: an unknown number of messages logged t = '
            f'{entry.message_start_time / 1e9:.3f} to {entry.message_end_time / 1e9:.3f} s'
            ) in said, said


def test_a_file_cut_at_a_chunk_boundary_lost_nothing_of_the_file(embedded_bag, tmp_path,
                                                                 capsys):
    entries, _ = chunk_contents(embedded_bag / 'bag.mcap')
    source = tmp_path / 'cut' / 'cut.mcap'
    source.parent.mkdir()
    source.write_bytes((embedded_bag / 'bag.mcap').read_bytes()[
        :entries[-1][0].chunk_start_offset])
    assert cli.main(['recover', str(source)]) == 0
    assert 'nothing in the file was lost, but it ends without its summary' in \
        capsys.readouterr().out


def test_a_chunk_index_that_disagrees_with_the_chunk_header_is_said(embedded_bag, tmp_path):
    """The summary is not checksummed (rosbags writes no summary CRC): a damaged chunk index
    entry is checked against the chunk's own header, and the disagreement is reported."""
    import struct

    entries, _ = chunk_contents(embedded_bag / 'bag.mcap')
    entry, held = max(entries, key=lambda pair: pair[1])
    data = bytearray((embedded_bag / 'bag.mcap').read_bytes())
    data[entry.chunk_start_offset + entry.chunk_length // 2] ^= 0x10
    key = struct.pack('<QQQ', entry.message_start_time, entry.message_end_time,
                      entry.chunk_start_offset)
    at = data.rindex(key)  # the chunk index entry, in the summary
    assert at > entry.chunk_start_offset + entry.chunk_length
    data[at + 8 + 7] ^= 0x01  # its end time now lies far in the future
    source = tmp_path / 's' / 's.mcap'
    source.parent.mkdir()
    source.write_bytes(bytes(data))
    (lost,) = recover_bag(source).lost
    assert lost.messages == held
    assert (f"the chunk's header says t = {entry.message_start_time / 1e9:.3f} to "
            f'{entry.message_end_time / 1e9:.3f} s') in lost.describe()

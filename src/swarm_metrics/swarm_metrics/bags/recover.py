"""Salvaging a bag whose writer was killed: rewrite every intact message as a valid bag.

A SIGKILLed writer leaves an MCAP file without its summary and footer, often ending inside a
chunk; rosbags and most tools refuse such a file. :func:`recover_bag` reads it front to back
with :class:`~swarm_metrics.bags.scan.McapScan` in tolerant mode (the mcap library's record
parsers, each chunk checked against its CRC), keeps every message of every intact chunk, skips
a damaged chunk whose frame is intact, stops where the framing breaks, and writes what it kept
through :class:`~swarm_metrics.bags.writer.EpisodeBagWriter`: a normal bag with metadata.yaml,
the seed and parameters in custom_data, and a ``recovered`` entry saying what was lost: each
chunk not kept, with its message count and log-time span read from the file's own indexes
(:mod:`swarm_metrics.bags.losses`). A closed bag's summary also lends the scan its channels, so a
damaged chunk that defined channels costs only its own messages.

The bytes are copied as they are (no re-serialization). PyPI's ``mcapfixindex`` only rebuilds
indexes of a file whose records are all complete, so it cannot handle a cut-off last chunk;
the mcap library's parsers plus this module's framing check can.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import shutil
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from rosbags.rosbag2.errors import WriterError
from rosbags.rosbag2.metadata import parse_qos

from mona_controller.topics import EPISODE
from swarm_metrics.bags.losses import LostChunk, lost_chunks, read_index
from swarm_metrics.bags.reader import decode_json, find_mcap, read_custom_data
from swarm_metrics.bags.scan import BagError, McapScan, TruncatedBagError
from swarm_metrics.bags.writer import CUSTOM_PREFIX, EpisodeBagWriter
from swarm_world.messages.cdr import TYPESTORE

T = TypeVar('T')
SUFFIX = '_recovered'


@dataclasses.dataclass
class RecoveryReport:
    """What :func:`recover_bag` kept and lost."""

    source: Path  #: the damaged .mcap
    target: Path  #: the recovered bag directory
    size: int  #: bytes of the source file
    good_bytes: int  #: bytes of the source up to the end of the last intact record
    messages: int
    topics: Counter[str]
    first_ns: int | None
    last_ns: int | None
    skipped_chunks: list[str]
    skipped_messages: int  #: intact messages of a type rosbags does not know
    stopped: str | None  #: why reading stopped before the end of the data ('' if it did not)
    was_complete: bool  #: the source's data section ended properly (a closed bag)
    lost: list[LostChunk] = dataclasses.field(default_factory=list)  #: chunks not kept
    indexed_messages: int | None = None  #: the source summary's message count, if any

    @property
    def lost_messages(self) -> int:
        """Messages of the source not in the recovered bag, as far as counted (see
        :attr:`lost_unknown`): those of the lost chunks and those of unknown types."""
        return sum(chunk.messages or 0 for chunk in self.lost) + self.skipped_messages

    @property
    def lost_unknown(self) -> bool:
        """A lost chunk whose message count the file does not say."""
        return any(chunk.messages is None for chunk in self.lost)

    @property
    def anything_lost(self) -> bool:
        """Whether a message of the source file is missing from the recovered bag."""
        return bool(self.lost) or self.skipped_messages > 0

    def to_dict(self) -> dict[str, Any]:
        """What was lost, for the recovered bag's ``recovered`` entry and for tools."""
        return {'source': str(self.source), 'kept_bytes': self.good_bytes, 'size': self.size,
                'messages': self.messages, 'skipped_chunks': len(self.skipped_chunks),
                'stopped': self.stopped, 'lost_messages': self.lost_messages,
                'lost_count_unknown': self.lost_unknown,
                'lost_chunks': [dataclasses.asdict(chunk) for chunk in self.lost]}

    def summary(self) -> str:
        """One paragraph for the user: what was kept, then exactly what was lost."""
        span = ('' if self.first_ns is None or self.last_ns is None else
                f', log time {self.first_ns / 1e9:.3f} to {self.last_ns / 1e9:.3f} s')
        text = (f'recovered {self.messages} messages on {len(self.topics)} topics{span} from '
                f'{self.source} into {self.target}')
        if not self.anything_lost:
            text += ('; the source bag was complete, nothing was lost' if self.was_complete
                     else f'; nothing in the file was lost, but it ends without its summary '
                          f'at byte {self.size} (the writer was killed?): what it had not '
                          'written yet is not in it')
            return text + '.'
        counted = (str(self.lost_messages) if not self.lost_unknown else
                   f'at least {self.lost_messages}' if self.lost_messages else
                   'an unknown number of')
        total = ('' if self.indexed_messages is None else
                 f" of the {self.indexed_messages} the source's summary counts")
        text += f'; LOST {counted} messages{total}'
        if self.lost:
            text += (f' in {len(self.lost)} chunk{"s" if len(self.lost) > 1 else ""}: '
                     + '; '.join(chunk.describe() for chunk in self.lost[:5])
                     + ('; ...' if len(self.lost) > 5 else ''))
        if self.skipped_messages:
            text += f'; dropped {self.skipped_messages} messages of unknown types'
        if self.skipped_chunks:
            text += '; why: ' + '; '.join(self.skipped_chunks[:3]) + (
                '; ...' if len(self.skipped_chunks) > 3 else '')
        if any(chunk.why == 'unread' for chunk in self.lost) and self.stopped:
            text += f'; reading stopped there: {self.stopped}'
        if not self.was_complete and self.size > self.good_bytes:
            text += f'; {self.size - self.good_bytes} bytes at the end were unreadable'
        return text + '.'


def default_target(path: str | Path) -> Path:
    """Where the recovered copy of a bag goes: ``<bag>_recovered`` beside it."""
    path = Path(path)
    base = path.parent / path.stem if path.suffix == '.mcap' else path
    return base.with_name(base.name + SUFFIX)


def recover_bag(source: str | Path, target: str | Path | None = None) -> RecoveryReport:
    """Rewrite every intact message of ``source`` (a bag directory or .mcap) as a new bag.

    Raises:
        BagError: ``source`` is not a readable MCAP bag at all, holds no intact message, or
            ``target`` exists.
    """
    mcap = find_mcap(source)
    target = Path(target) if target is not None else default_target(source)
    if target.exists():
        raise BagError(f'{target} exists already; remove it or choose another --out')
    scan = McapScan(mcap, strict=False)
    index = read_index(mcap)  # a closed bag's channels: a damaged chunk may define some
    scan.know(index.schemas, index.channels)
    messages = iter(scan)
    first = next(messages, None)  # a file that is no bag at all fails here, writing nothing
    if first is None:
        raise BagError(f'{mcap}: nothing to recover: {scan.report.problem or "no messages"} '
                       f'({scan.report.readable()})')
    topics: Counter[str] = Counter()
    skipped, announcement = 0, None
    try:
        with EpisodeBagWriter(target) as bag:
            for message in itertools.chain([first], messages):
                if message.msgtype not in TYPESTORE.fielddefs:
                    skipped += 1
                    continue
                if not bag.has_topic(message.topic):
                    bag.add_topic(message.topic, message.msgtype,
                                  _qos(scan, message.topic))
                bag.write(message.topic, message.log_time, message.data)
                topics[message.topic] += 1
                if message.topic == EPISODE and announcement is None:
                    try:
                        announcement = decode_json(message)
                    except BagError:
                        pass
            custom = read_custom_data(source) or scan.report.custom
            for key, value in custom.items():
                if key.startswith(CUSTOM_PREFIX):
                    bag.set_custom(key[len(CUSTOM_PREFIX):], str(value))
            if announcement is not None:
                bag.describe(announcement)
            found = scan.report
            lost, index = lost_chunks(
                mcap, intact=scan.intact_chunks, damaged=found.bad_chunk_offsets,
                stopped_at=None if found.data_complete else found.good_bytes)
            report = RecoveryReport(
                mcap, target, found.size, found.good_bytes, sum(topics.values()), topics,
                found.first_ns, found.last_ns, found.bad_chunks, skipped,
                found.problem or '', found.data_complete, lost, index.messages)
            bag.set_custom('recovered', json.dumps(report.to_dict()))
    except WriterError as error:
        shutil.rmtree(target, ignore_errors=True)
        raise BagError(f'cannot write {target}: {error}') from None
    except BaseException:
        shutil.rmtree(target, ignore_errors=True)
        raise
    return report


def _qos(scan: McapScan, topic: str) -> list[Any]:
    """The offered QoS profiles recorded with ``topic`` (none if unreadable)."""
    for known in scan.topics.values():
        if known.topic == topic and known.offered_qos:
            try:
                return parse_qos(known.offered_qos)
            except Exception:  # noqa: BLE001 - QoS is a courtesy to players, not data
                return []
    return []


def with_recovery(path: str | Path, read: Callable[[Path], T]) -> tuple[T, str | None]:
    """``read(path)``; if the bag was cut short, recover it (once) and read the copy.

    Returns:
        (the result, a note for the user when the recovered copy was used).
    """
    path = Path(path)
    try:
        return read(path), None
    except TruncatedBagError as error:
        target = default_target(path)
        if target.exists():
            try:
                return read(target), f'{path} was cut short; read its recovered copy {target}'
            except BagError:
                raise BagError(f'{error} Its recovered copy {target} is unreadable too: '
                               f'delete it and run `mona-swarm recover` again.') from None
        report = recover_bag(path, target)
        return read(target), f'{path} was cut short: {report.summary()}'

"""One strict pass over an MCAP file: its messages as stored, and what it found.

The MCAP file is the truth of a bag (:mod:`swarm_metrics.bags.reader`). :class:`McapScan`
reads it front to back with the mcap library's record parsers under a strict frame check,
so every problem becomes a :class:`BagError` that says what is wrong, where, and what could
be read:

* a file cut short (a killed writer) raises :class:`TruncatedBagError`; ``mona-swarm recover``
  (:mod:`swarm_metrics.bags.recover`) rewrites everything before the cut as a valid bag, with
  a tolerant scan (``strict=False``) that notes the problem and skips a damaged chunk;
* a damaged chunk (CRC, compression or framing) or a summary that disagrees with the data
  raises :class:`BagError`.
"""

from __future__ import annotations

import dataclasses
import os
import struct
from collections import Counter
from collections.abc import Iterator
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO

import yaml
from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Chunk, ChunkIndex, Header, Message, Metadata, Schema, Statistics
from mcap.stream_reader import breakup_chunk

MAGIC = b'\x89MCAP0\r\n'
(HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, MESSAGE_INDEX, CHUNK_INDEX, ATTACHMENT,
 ATTACHMENT_INDEX, STATISTICS, METADATA, METADATA_INDEX, SUMMARY_OFFSET, DATA_END) = range(1, 16)
#: Records that may sit between the chunks of the data section, and in the summary section.
_DATA_RECORDS = {MESSAGE_INDEX, ATTACHMENT, METADATA}
_SUMMARY_RECORDS = {SCHEMA, CHANNEL, ATTACHMENT_INDEX, METADATA_INDEX, SUMMARY_OFFSET, METADATA}
#: No chunk we write comes near this; a larger claim is damage, not a reason to allocate.
MAX_CHUNK_BYTES = 256 * 2**20


class BagError(Exception):
    """A bag that cannot be read as it is. The message says what is wrong and what was read."""


class TruncatedBagError(BagError):
    """The file ends before the bag was closed (its writer was killed); recoverable."""


@dataclasses.dataclass(frozen=True)
class RawMessage:
    """One message as stored: serialized CDR bytes and the sim time it describes."""

    topic: str
    msgtype: str
    log_time: int  #: ns
    data: bytes


@dataclasses.dataclass(frozen=True)
class Topic:
    """A channel of the bag: its topic, type and the QoS profiles its publisher offered."""

    topic: str
    msgtype: str
    offered_qos: str  #: YAML, as rosbag2 stores it ('' when unknown)


@dataclasses.dataclass
class ScanReport:
    """What one pass over an MCAP file found."""

    path: Path
    size: int
    messages: int = 0
    chunks: int = 0
    bad_chunks: list[str] = dataclasses.field(default_factory=list)
    bad_chunk_offsets: list[int] = dataclasses.field(default_factory=list)  #: their bytes
    topics: Counter[str] = dataclasses.field(default_factory=Counter)
    first_ns: int | None = None
    last_ns: int | None = None
    good_bytes: int = 0  #: the file up to the end of the last intact record
    data_complete: bool = False  #: the data section ended properly (DataEnd record)
    complete: bool = False  #: the footer and a consistent summary were read
    problem: str | None = None  #: why reading stopped early
    custom: dict[str, str] = dataclasses.field(default_factory=dict)  #: rosbag2 custom_data

    def readable(self) -> str:
        """'N messages on K topics in C chunks (sim time a to b s)', for error messages."""
        span = ('' if self.first_ns is None or self.last_ns is None else
                f', log time {self.first_ns / 1e9:.3f} to {self.last_ns / 1e9:.3f} s')
        return (f'{self.messages} messages on {len(self.topics)} topics in {self.chunks} '
                f'intact chunks ({self.good_bytes} of {self.size} bytes{span})')


class McapScan:
    """One front-to-back pass over an MCAP file, yielding its messages in file order.

    Args:
        path: the .mcap file.
        strict: raise :class:`BagError` at the first problem (the default). Otherwise note it
            in :attr:`report`, skip a damaged chunk whose frame is intact, and stop at a break
            in the framing or at the end of the data section; used by recovery.
    """

    def __init__(self, path: str | Path, *, strict: bool = True) -> None:
        self.path = Path(path)
        self.strict = strict
        self.report = ScanReport(self.path, 0)
        self.topics: dict[int, Topic] = {}  #: by channel id
        self._schemas: dict[int, str] = {}
        self._chunk_offsets: list[int] = []
        self._indexed_offsets: list[int] = []
        self._statistics: Statistics | None = None
        self._counts: Counter[int] = Counter()  # by channel id

    def know(self, schemas: dict[int, str], channels: list[Channel]) -> None:
        """Take schemas (id -> name) and channels from elsewhere (the summary of a damaged
        bag), so a message whose channel was defined in a damaged chunk can still be read."""
        self._schemas.update(schemas)
        for item in channels:
            self.topics.setdefault(item.id, Topic(
                item.topic, self._schemas.get(item.schema_id, ''),
                item.metadata.get('offered_qos_profiles', '')))

    @property
    def intact_chunks(self) -> list[int]:
        """The byte offsets of the chunks read intact so far."""
        return list(self._chunk_offsets)

    def __iter__(self) -> Iterator[RawMessage]:
        try:
            handle = open(self.path, 'rb')
        except OSError as error:
            raise BagError(f'cannot open {self.path}: {error.strerror}') from None
        with handle:
            self.report.size = os.fstat(handle.fileno()).st_size
            yield from self._scan(handle)

    def _fail(self, message: str, *, truncated: bool = False, damaged: bool = False) -> None:
        """Stop here: raise in strict mode, else remember why reading stopped."""
        text = f'{self.path}: {message}. Readable before that: {self.report.readable()}.'
        if truncated:
            text += (' The writer did not close the bag (killed?); `mona-swarm recover` '
                     'rewrites the readable part as a valid bag.')
        elif damaged:
            text += (' `mona-swarm recover` keeps every intact chunk in a new bag and reports '
                     'what the damaged ones held.')
        if self.strict:
            raise (TruncatedBagError if truncated else BagError)(text)
        self.report.problem = text

    def _record(self, handle: BinaryIO) -> tuple[int, int, bytes] | None:
        """The next (offset, opcode, body), or None (after :meth:`_fail`) if it is cut off."""
        offset = handle.tell()
        head = handle.read(9)
        if len(head) < 9:
            self._fail(f'the file ends at byte {offset}' + (
                ' inside a record header' if head else ' without the MCAP summary and footer'),
                truncated=True)
            return None
        opcode, length = struct.unpack('<BQ', head)
        if length > self.report.size - offset - 9:
            self._fail(f'the record at byte {offset} (type 0x{opcode:02x}) claims {length} '
                       f'bytes but the file has only {self.report.size - offset - 9} more: '
                       f'it is cut short or damaged', truncated=True)
            return None
        return offset, opcode, handle.read(length)

    def _scan(self, handle: BinaryIO) -> Iterator[RawMessage]:
        magic = handle.read(8)
        if magic != MAGIC:
            if MAGIC.startswith(magic):
                raise BagError(f'{self.path} ends inside its MCAP header (it has '
                               f'{len(magic)} bytes): nothing is readable')
            raise BagError(f'{self.path} is not an MCAP file (no MCAP magic at its start)')
        try:
            first = self._record(handle)
        except TruncatedBagError:
            first = None
        if first is None:
            raise BagError(f'{self.path} ends inside its MCAP header: nothing is readable')
        try:
            header = Header.read(ReadDataStream(BytesIO(first[2])))
        except Exception:  # noqa: BLE001 - any parse failure of untrusted bytes is damage
            header = None
        if first[1] != HEADER or header is None or header.profile != 'ros2':
            raise BagError(f'{self.path} is not a ROS 2 bag (its MCAP header is missing or '
                           f'has another profile)')
        self.report.good_bytes = handle.tell()
        summary = False
        while (record := self._record(handle)) is not None:
            offset, opcode, body = record
            if not summary and opcode == CHUNK:
                records = self._chunk(offset, body)
                if records is None:
                    if self.strict or self.report.problem:
                        return
                    self.report.good_bytes = handle.tell()
                    continue
                self.report.chunks += 1
                self._chunk_offsets.append(offset)
                messages = self._messages(records)
                if messages is None:
                    return
                self.report.good_bytes = handle.tell()
                yield from messages
            elif not summary and opcode == DATA_END:
                self.report.good_bytes = handle.tell()
                self.report.data_complete = summary = True
                if not self.strict:
                    return
            elif not summary and opcode in _DATA_RECORDS:
                if opcode == METADATA and not self._metadata(offset, body):
                    return
                self.report.good_bytes = handle.tell()
            elif summary and opcode == FOOTER:
                self._finish(handle, offset)
                return
            elif summary and opcode in _SUMMARY_RECORDS | {STATISTICS, CHUNK_INDEX}:
                if not self._summary(offset, opcode, body):
                    return
            else:
                where = 'summary' if summary else 'data section'
                self._fail(f'unexpected record type 0x{opcode:02x} at byte {offset} in the '
                           f'{where}: the file is damaged')
                return

    def _chunk(self, offset: int, body: bytes) -> list[Any] | None:
        """The records of a chunk, checked (CRC, sizes); None if it is damaged."""
        try:
            stream = ReadDataStream(BytesIO(body))
            chunk = Chunk.read(stream)
            if stream.count != len(body) or chunk.uncompressed_size > MAX_CHUNK_BYTES:
                raise ValueError('inconsistent chunk sizes')
            if chunk.compression not in ('', 'zstd', 'lz4'):
                raise ValueError(f'unknown compression {chunk.compression!r}')
            return breakup_chunk(chunk, validate_crc=True)
        except Exception as error:  # noqa: BLE001 - any failure to decode it is damage
            text = f'the chunk at byte {offset} is damaged ({error or type(error).__name__})'
            self.report.bad_chunks.append(text)
            self.report.bad_chunk_offsets.append(offset)
            if self.strict:
                self._fail(text, damaged=True)
            return None

    def _messages(self, records: list[Any]) -> list[RawMessage] | None:
        """The messages of one chunk's records, registering its schemas and channels."""
        out = []
        for item in records:
            if isinstance(item, Schema):
                self._schemas[item.id] = item.name
            elif isinstance(item, Channel):
                self.topics[item.id] = Topic(item.topic, self._schemas.get(item.schema_id, ''),
                                             item.metadata.get('offered_qos_profiles', ''))
            elif isinstance(item, Message):
                topic = self.topics.get(item.channel_id)
                if topic is None or not topic.msgtype:
                    self._fail(f'a message refers to unknown channel {item.channel_id}')
                    return None
                out.append(RawMessage(topic.topic, topic.msgtype, item.log_time, item.data))
        report = self.report
        for message in out:
            report.messages += 1
            report.topics[message.topic] += 1
            if report.first_ns is None or report.last_ns is None:
                report.first_ns = report.last_ns = message.log_time
            else:
                report.first_ns = min(report.first_ns, message.log_time)
                report.last_ns = max(report.last_ns, message.log_time)
        self._counts.update(item.channel_id for item in records if isinstance(item, Message))
        return out

    def _metadata(self, offset: int, body: bytes) -> bool:
        """Read rosbag2's custom_data from its MCAP metadata record (kept if parseable)."""
        try:
            record = Metadata.read(ReadDataStream(BytesIO(body)))
            if record.name == 'rosbag2':
                info = yaml.safe_load(record.metadata.get('serialized_metadata', '')) or {}
                self.report.custom = dict(info.get('custom_data') or {})
        except Exception:  # noqa: BLE001
            self._fail(f'the metadata record at byte {offset} is damaged')
            return False
        return True

    def _summary(self, offset: int, opcode: int, body: bytes) -> bool:
        """Keep what the consistency check needs from a summary record."""
        try:
            stream = ReadDataStream(BytesIO(body))
            if opcode == STATISTICS:
                self._statistics = Statistics.read(stream)
            elif opcode == CHUNK_INDEX:
                self._indexed_offsets.append(ChunkIndex.read(stream).chunk_start_offset)
        except Exception:  # noqa: BLE001
            self._fail(f'the summary record at byte {offset} is damaged')
            return False
        return True

    def _finish(self, handle: BinaryIO, offset: int) -> None:
        """Check the footer's trailing magic and that the summary agrees with the data."""
        tail = handle.read()
        if tail != MAGIC:
            self._fail(f'the footer at byte {offset} is not followed by the MCAP end magic',
                       truncated=MAGIC.startswith(tail))
            return
        stats = self._statistics
        if stats is not None and (stats.message_count != self.report.messages
                                  or stats.chunk_count != len(self._chunk_offsets)
                                  or {k: v for k, v in stats.channel_message_counts.items()
                                      if v} != dict(self._counts)):
            self._fail(f'the summary counts {stats.message_count} messages in '
                       f'{stats.chunk_count} chunks, the data holds {self.report.messages} in '
                       f'{len(self._chunk_offsets)}: the file is damaged')
            return
        if self._indexed_offsets and sorted(self._indexed_offsets) != self._chunk_offsets:
            self._fail('the chunk index does not match the chunks: the file is damaged')
            return
        self.report.complete = True

"""What a damaged or cut-short bag lost: the chunks recovery could not keep, each with its
message count and the log (sim) time span its messages covered, read from the file's own
indexes rather than guessed.

Where the figures come from, best first:

* the summary's chunk index (a closed bag): every chunk's offset and message start and end
  time, and the offsets of its message index records, whose entries are one per message;
  every indexed chunk that was not read intact is lost, wherever reading stopped;
* without a summary (a killed writer): the damaged chunk's own header (its start and end
  time) and the message index records that follow it in the data section;
* a chunk cut off by the end of the file: its header's times, if they made it to disk; its
  message count is unknown (its message index was never written).

Everything here reads untrusted bytes: any record that does not parse is taken as absent, so
a figure is either read from the file or reported unknown, never made up.
"""

from __future__ import annotations

import dataclasses
import struct
import zlib
from collections.abc import Iterable
from io import BytesIO
from pathlib import Path
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.records import Channel, ChunkIndex, Footer, MessageIndex, Schema, Statistics

MAGIC = b'\x89MCAP0\r\n'
SCHEMA, CHANNEL, CHUNK, MESSAGE_INDEX, CHUNK_INDEX = 0x03, 0x04, 0x06, 0x07, 0x08
STATISTICS, FOOTER, DATA_END = 0x0B, 0x02, 0x0F
FOOTER_BYTES = 9 + 20  # opcode, length, then summary start, summary offset start, CRC


@dataclasses.dataclass(frozen=True)
class LostChunk:
    """One chunk of the source that is not in the recovered bag."""

    offset: int  #: its byte offset in the source file
    why: str  #: 'damaged', 'cut off' (by the end of the file) or 'unread' (after a break)
    messages: int | None  #: how many messages it held (None: unknown)
    start_ns: int | None  #: the log time of its first message (None: unknown)
    end_ns: int | None  #: the log time of its last message
    source: str  #: where the figures were read

    def describe(self) -> str:
        """'the damaged chunk at byte 1822: 62 messages logged t = 4.000 to 10.016 s'."""
        count = ('an unknown number of messages' if self.messages is None else
                 f'{self.messages} message{"" if self.messages == 1 else "s"}')
        span = ('' if self.start_ns is None or self.end_ns is None else
                f' logged t = {self.start_ns / 1e9:.3f} to {self.end_ns / 1e9:.3f} s')
        return (f'the {self.why.replace(" ", "-")} chunk at byte {self.offset}: {count}{span} '
                f'({self.source})')


@dataclasses.dataclass(frozen=True)
class Index:
    """What a closed bag's summary says about its chunks (empty if it has none)."""

    chunks: dict[int, ChunkIndex]  #: by chunk start offset
    messages: int | None  #: the statistics' message count
    schemas: dict[int, str] = dataclasses.field(default_factory=dict)  #: id -> type name
    channels: list[Channel] = dataclasses.field(default_factory=list)


def read_index(path: str | Path) -> Index:
    """The summary index of the MCAP file ``path`` (empty if it has none)."""
    with open(path, 'rb') as handle:
        return summary_index(handle, handle.seek(0, 2))


def lost_chunks(path: str | Path, *, intact: Iterable[int], damaged: Iterable[int],
                stopped_at: int | None) -> tuple[list[LostChunk], Index]:
    """The chunks of ``path`` that recovery did not keep, in file order, and the summary index.

    Args:
        path: the source .mcap.
        intact: offsets of the chunks read intact.
        damaged: offsets of the chunks skipped as damaged.
        stopped_at: where reading stopped before the end of the data section (None if it
            did not): a chunk starting there was cut off or its frame is broken.
    """
    intact, damaged = set(intact), sorted(set(damaged))
    with open(path, 'rb') as handle:
        size = handle.seek(0, 2)
        index = summary_index(handle, size)
        if index.chunks:  # the summary knows every chunk: all those not read intact are lost
            return [_indexed(handle, size, entry, 'damaged' if offset in damaged else 'unread')
                    for offset, entry in sorted(index.chunks.items())
                    if offset not in intact], index
        lost = [_unindexed(handle, size, offset, 'damaged') for offset in damaged]
        if stopped_at is not None:
            lost += [_unindexed(handle, size, offset, why)
                     for offset, why in _chunks_from(handle, size, stopped_at)
                     if offset not in damaged]
        return lost, index


def _chunks_from(handle: BinaryIO, size: int, offset: int) -> list[tuple[int, str]]:
    """The chunks from ``offset`` to the end of the data section, by their framing: each
    whole one 'unread', one the end of the file cuts 'cut off'."""
    found = []
    while (head := _record_head(handle, size, offset)) is not None and head[0] != DATA_END:
        whole = offset + 9 + head[1] <= size
        if head[0] == CHUNK:
            found.append((offset, 'unread' if whole else 'cut off'))
        if not whole:
            break
        offset += 9 + head[1]
    return found


def summary_index(handle: BinaryIO, size: int) -> Index:
    """The chunk index, message count, schemas and channels of a file's summary (empty if
    it is absent, or damaged: its CRC in the footer does not match, or a record does not
    parse)."""
    empty = Index({}, None)
    if size < 8 + FOOTER_BYTES + 8:
        return empty
    handle.seek(size - 8 - FOOTER_BYTES)
    tail = handle.read(FOOTER_BYTES + 8)
    if tail[-8:] != MAGIC or tail[0] != FOOTER:
        return empty
    try:
        footer = Footer.read(ReadDataStream(BytesIO(tail[9:FOOTER_BYTES])))
    except Exception:  # noqa: BLE001 - damage: no summary to go by
        return empty
    end = size - 8 - FOOTER_BYTES
    if not 0 < footer.summary_start < end:
        return empty
    if footer.summary_crc:  # the summary is trusted only whole (0: the writer gave no CRC)
        handle.seek(footer.summary_start)
        covered = handle.read(end - footer.summary_start) + tail[:9 + 16]
        if zlib.crc32(covered) != footer.summary_crc:
            return empty
    chunks: dict[int, ChunkIndex] = {}
    schemas: dict[int, str] = {}
    channels: list[Channel] = []
    messages = None
    offset = footer.summary_start
    while offset < end:
        record = _record(handle, end, offset)
        if record is None:
            return empty  # a summary that does not parse is no guide
        opcode, body = record
        try:
            if opcode == CHUNK_INDEX:
                entry = ChunkIndex.read(ReadDataStream(BytesIO(body)))
                chunks[entry.chunk_start_offset] = entry
            elif opcode == STATISTICS:
                messages = Statistics.read(ReadDataStream(BytesIO(body))).message_count
            elif opcode == SCHEMA:
                schema = Schema.read(ReadDataStream(BytesIO(body)))
                schemas[schema.id] = schema.name
            elif opcode == CHANNEL:
                channels.append(Channel.read(ReadDataStream(BytesIO(body))))
        except Exception:  # noqa: BLE001
            return empty
        offset += 9 + len(body)
    return Index(chunks, messages, schemas, channels)


def _indexed(handle: BinaryIO, size: int, entry: ChunkIndex, why: str) -> LostChunk:
    """A lost chunk the summary indexes: its times from the index, its count from its
    message index records (one entry per message). Neither the summary nor a chunk's header
    is checksummed (rosbags writes no summary CRC), so each figure is checked against the
    other copy in the data section, and a disagreement is said, not settled."""
    offset = entry.chunk_start_offset
    count = _index_entries(handle, size, entry.message_index_offsets.values())
    notes = []
    if count is None:
        notes.append('its message index is unreadable')
    head = _record_head(handle, size, offset)
    if head is not None and head[0] == CHUNK and offset + 9 + head[1] <= size:
        after = _following_entries(handle, size, offset + 9 + head[1])
        if after is not None and count is not None and after != count:
            notes.append(f'the message index after the chunk counts {after}')
    times = _chunk_times(handle, size, offset)
    if times is not None and times != (entry.message_start_time, entry.message_end_time):
        notes.append(f"the chunk's header says t = {times[0] / 1e9:.3f} to "
                     f'{times[1] / 1e9:.3f} s')
    return LostChunk(offset, why, count, entry.message_start_time, entry.message_end_time,
                     '; '.join(['the chunk index', *notes]))


def _unindexed(handle: BinaryIO, size: int, offset: int, why: str) -> LostChunk:
    """A lost chunk without a summary: its header's times and the message index records
    that follow it (none for a chunk cut off by the end of the file)."""
    times = _chunk_times(handle, size, offset)
    head = _record_head(handle, size, offset)
    count = None
    if head is not None and offset + 9 + head[1] <= size:
        count = _following_entries(handle, size, offset + 9 + head[1])
    source = ('its header and message index' if count is not None else
              'its header; no message index' if times else 'nothing readable')
    start, end = times or (None, None)
    return LostChunk(offset, why, count, start, end, source)


def _record_head(handle: BinaryIO, size: int, offset: int) -> tuple[int, int] | None:
    """(opcode, length) of the record at ``offset``, or None past the end of the file."""
    if offset + 9 > size:
        return None
    handle.seek(offset)
    opcode, length = struct.unpack('<BQ', handle.read(9))
    return opcode, length


def _record(handle: BinaryIO, end: int, offset: int) -> tuple[int, bytes] | None:
    """(opcode, body) of a whole record at ``offset`` ending by ``end``, else None."""
    head = _record_head(handle, end, offset)
    if head is None or offset + 9 + head[1] > end:
        return None
    return head[0], handle.read(head[1])


def _chunk_times(handle: BinaryIO, size: int, offset: int) -> tuple[int, int] | None:
    """A chunk header's message start and end times, if on disk and ordered."""
    head = _record_head(handle, size, offset)
    if head is None or head[0] != CHUNK or offset + 9 + 16 > size:
        return None
    start, end = struct.unpack('<QQ', handle.read(16))
    return (start, end) if start <= end else None


def _index_entries(handle: BinaryIO, size: int, offsets: Iterable[int]) -> int | None:
    """The entries of the message index records at ``offsets`` (None if one is unreadable)."""
    total = 0
    for offset in offsets:
        record = _record(handle, size, offset)
        if record is None or record[0] != MESSAGE_INDEX:
            return None
        try:
            total += len(MessageIndex.read(ReadDataStream(BytesIO(record[1]))).records)
        except Exception:  # noqa: BLE001
            return None
    return total


def _following_entries(handle: BinaryIO, size: int, offset: int) -> int | None:
    """The entries of the message index records directly after a chunk (None if none)."""
    total, found = 0, False
    while (record := _record(handle, size, offset)) is not None and record[0] == MESSAGE_INDEX:
        try:
            total += len(MessageIndex.read(ReadDataStream(BytesIO(record[1]))).records)
        except Exception:  # noqa: BLE001
            return None
        found, offset = True, offset + 9 + len(record[1])
    return total if found else None

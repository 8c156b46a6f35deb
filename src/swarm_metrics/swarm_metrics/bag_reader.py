"""Reading episode bags (a rosbag2 directory or its .mcap file) into tables.

The MCAP file is the truth: metadata.yaml may be missing (a writer that never closed) and is
only consulted for ``custom_data``. The file is read front to back with the mcap library's
record parsers under a strict frame check, so every problem becomes a :class:`BagError` that
says what is wrong, where, and what could be read:

* a file cut short (a killed writer) raises :class:`TruncatedBagError`; ``mona-swarm recover``
  (:mod:`swarm_metrics.recover`) rewrites everything before the cut as a valid bag;
* a damaged chunk (CRC, compression or framing) or a summary that disagrees with the data
  raises :class:`BagError`.

Messages are decoded with rosbags' ROS 2 Jazzy typestore, so no ROS installation is needed.
"""

from __future__ import annotations

import dataclasses
import json
import os
import struct
from collections import Counter
from collections.abc import Iterator
from io import BytesIO
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Chunk, ChunkIndex, Header, Message, Metadata, Schema, Statistics
from mcap.stream_reader import breakup_chunk

from mona_controller.contract import (
    CLEANING,
    CUE_MAP,
    EPISODE,
    METRICS_PREFIX,
    POSES,
    ROBOT_STATES,
    SOURCES,
    STATUS,
)
from swarm_metrics.bag_writer import CUSTOM_PREFIX, TYPESTORE
from swarm_world import arena_markers
from swarm_world.frames import poses_from_rows
from swarm_world.timing import crossed

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
    topics: Counter = dataclasses.field(default_factory=Counter)
    first_ns: int | None = None
    last_ns: int | None = None
    good_bytes: int = 0  #: the file up to the end of the last intact record
    data_complete: bool = False  #: the data section ended properly (DataEnd record)
    complete: bool = False  #: the footer and a consistent summary were read
    problem: str | None = None  #: why reading stopped early
    custom: dict[str, str] = dataclasses.field(default_factory=dict)  #: rosbag2 custom_data

    def readable(self) -> str:
        """'N messages on K topics in C chunks (sim time a to b s)', for error messages."""
        span = ('' if self.first_ns is None else
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
        self._counts: Counter = Counter()  # by channel id

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

    def _record(self, handle) -> tuple[int, int, bytes] | None:
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

    def _scan(self, handle) -> Iterator[RawMessage]:
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

    def _chunk(self, offset: int, body: bytes) -> list | None:
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

    def _messages(self, records: list) -> list[RawMessage] | None:
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
            if report.first_ns is None:
                report.first_ns = report.last_ns = message.log_time
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

    def _finish(self, handle, offset: int) -> None:
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


# --- locating a bag -----------------------------------------------------------------------

def find_mcap(path: str | Path) -> Path:
    """The MCAP file of a bag given as a directory (rosbag2 layout) or as the file itself."""
    path = Path(path)
    if path.is_file():
        return path
    if not path.exists():
        raise BagError(f'{path} does not exist')
    if not path.is_dir():
        raise BagError(f'{path} is neither a bag directory nor an .mcap file')
    named = path / f'{path.name}.mcap'
    if named.is_file():
        return named
    files = sorted(path.glob('*.mcap'))
    if len(files) != 1:
        raise BagError(f'{path} holds {len(files)} .mcap files; expected one (a rosbag2 bag '
                       f'directory written with MCAP storage)')
    return files[0]


def read_custom_data(path: str | Path) -> dict[str, str]:
    """``custom_data`` of the bag's metadata.yaml ({} if it is missing or unreadable)."""
    path = Path(path)
    directory = path if path.is_dir() else path.parent
    try:
        info = yaml.safe_load((directory / 'metadata.yaml').read_text())
        return dict(info['rosbag2_bagfile_information'].get('custom_data') or {})
    except Exception:  # noqa: BLE001 - metadata.yaml is optional; the MCAP is the truth
        return {}


# --- decoding -----------------------------------------------------------------------------

def decode(message: RawMessage) -> Any:
    """The message as a rosbags object (attribute access like the rclpy message)."""
    try:
        return TYPESTORE.deserialize_cdr(message.data, message.msgtype)
    except Exception as error:  # noqa: BLE001 - foreign or damaged bytes
        raise BagError(f'a {message.msgtype} message on {message.topic} at log time '
                       f'{message.log_time / 1e9:.3f} s cannot be decoded ({error})') from None


def decode_json(message: RawMessage) -> dict:
    """A std_msgs/String message holding a JSON object (/episode, /world/status)."""
    try:
        value = json.loads(decode(message).data)
    except ValueError:
        value = None
    if not isinstance(value, dict):
        raise BagError(f'{message.topic} at log time {message.log_time / 1e9:.3f} s does not '
                       f'hold a JSON object')
    return value


def poses_of(msg: Any) -> np.ndarray:
    """[N, 3] float64 (x, y, yaw) of a geometry_msgs/PoseArray (yaw of a z-axis quaternion)."""
    return poses_from_rows([(p.position.x, p.position.y, p.orientation.z, p.orientation.w)
                            for p in msg.poses])


def cue_of(msg: Any) -> np.ndarray:
    """The uint8 raster of a /world/cue_map image in core order (row 0 at y = 0)."""
    if msg.encoding != 'mono8' or len(msg.data) != msg.height * msg.step \
            or msg.step < msg.width:
        raise BagError(f'/world/cue_map is not a mono8 image ({msg.height} x {msg.width} '
                       f'{msg.encoding!r}, {len(msg.data)} bytes)')
    data = np.asarray(msg.data, dtype=np.uint8).reshape(msg.height, msg.step)
    return data[::-1, :msg.width].copy()


# --- episode tables -----------------------------------------------------------------------

@dataclasses.dataclass
class EpisodeBag:
    """One episode's bag as tables (times are log times in ns)."""

    path: Path  #: the .mcap file
    report: ScanReport
    custom: dict[str, str]  #: rosbag2 custom_data (metadata.yaml, else the MCAP's copy)
    announcement: dict | None = None  #: the supervisor's /episode message
    status: list[tuple[int, dict]] = dataclasses.field(default_factory=list)
    poses: list[tuple[int, np.ndarray]] = dataclasses.field(default_factory=list)
    cleaning: list[tuple[int, np.ndarray]] = dataclasses.field(default_factory=list)
    cue_maps: list[tuple[int, np.ndarray]] = dataclasses.field(default_factory=list)
    metrics: dict[str, list[tuple[int, float]]] = dataclasses.field(default_factory=dict)
    #: each /world/robot_states: (log time, uint8 [N] states)
    states: list[tuple[int, np.ndarray]] = dataclasses.field(default_factory=list)
    #: each /world/sources: (log time, ((name, x, y), ...))
    sources: list[tuple[int, tuple[tuple[str, float, float], ...]]] = dataclasses.field(
        default_factory=list)

    @property
    def seed(self) -> int | None:
        """The episode seed (from the announcement, else from custom_data)."""
        if self.announcement is not None and 'seed' in self.announcement:
            return self.announcement['seed']
        value = self.custom.get(CUSTOM_PREFIX + 'seed')
        return int(value) if value is not None and value.isdigit() else None

    @property
    def parameters(self) -> dict | None:
        """Every parameter by section (from the announcement, else from custom_data)."""
        if self.announcement is not None and 'parameters' in self.announcement:
            return self.announcement['parameters']
        try:
            return json.loads(self.custom[CUSTOM_PREFIX + 'parameters'])
        except (KeyError, ValueError):
            return None

    @property
    def plugins(self) -> list:
        """The plug-in records of the run (from the announcement, else from custom_data;
        none if it recorded none)."""
        if self.announcement is not None and 'parameters' in self.announcement:
            return self.announcement.get('plugins') or []
        try:
            return json.loads(self.custom[CUSTOM_PREFIX + 'plugins'])
        except (KeyError, ValueError):
            return []

    def metric(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(log times ns, values) of /metrics/<name> as recorded online."""
        rows = self.metrics.get(name, [])
        return (np.array([t for t, _ in rows], dtype=np.int64),
                np.array([v for _, v in rows], dtype=np.float64))


def _sample_ns(announcement: dict) -> int | None:
    """The metrics sample period (ns) an announcement declares, if it is well formed."""
    try:
        period = float(announcement['parameters']['metrics']['sample_period'])
        return round(period * 1e9) if period > 0 else None
    except (KeyError, TypeError, ValueError, OverflowError):
        return None


def read_episode_bag(path: str | Path) -> EpisodeBag:
    """Read a complete episode bag into tables; poses are kept at the metrics sample times.

    Raises:
        TruncatedBagError: the writer never closed the bag (recover it first).
        BagError: the bag is damaged or not an episode bag.
    """
    mcap = find_mcap(path)
    scan = McapScan(mcap)
    bag = EpisodeBag(mcap, scan.report, {})
    start_ns = sample_ns = previous = None
    for message in scan:
        topic = message.topic
        if topic == POSES:
            # A pose is kept if it is the first at or after a sample boundary (the rule the
            # metrics node samples and decimates by); until the announcement, keep them all.
            if sample_ns is not None:
                due = crossed(previous - start_ns, message.log_time - start_ns, sample_ns)
                previous = message.log_time
                if not due:
                    continue
            bag.poses.append((message.log_time, poses_of(decode(message))))
        elif topic == CLEANING:
            bag.cleaning.append((message.log_time, poses_of(decode(message))))
        elif topic.startswith(METRICS_PREFIX):
            bag.metrics.setdefault(topic[len(METRICS_PREFIX):], []).append(
                (message.log_time, float(decode(message).data)))
        elif topic == STATUS:
            bag.status.append((message.log_time, decode_json(message)))
        elif topic == CUE_MAP:
            bag.cue_maps.append((message.log_time, cue_of(decode(message))))
        elif topic == ROBOT_STATES:
            bag.states.append((message.log_time,
                               np.frombuffer(bytes(decode(message).data), dtype=np.uint8)))
        elif topic == SOURCES:
            bag.sources.append((message.log_time,
                                arena_markers.sources_from_markers(decode(message).markers)))
        elif topic == EPISODE:
            announcement = decode_json(message)
            if bag.announcement is None and 'shutdown' not in announcement:
                bag.announcement = announcement
                start_ns = previous = announcement.get('start_ns')
                sample_ns = _sample_ns(announcement) if isinstance(start_ns, int) else None
    bag.custom = read_custom_data(path) or scan.report.custom
    return bag

"""Writing one episode's bag: rosbag2 layout, MCAP storage, zstd chunks (rosbags, ROS 2 Jazzy).

The bag is the directory ``<path>`` holding ``<path>/<name>.mcap`` and ``metadata.yaml``.
Messages are written as the serialized CDR bytes that arrived, never re-serialized, with the
sim time they describe as their log time.

Two things go beyond rosbags' own writer, because a bag must survive a crash of its writer:

* the open chunk is ended every ``chunk_period`` of log (sim) time and pushed to the operating
  system, so a SIGKILL loses at most that much: the messages of the one unfinished chunk;
* every chunk carries the CRC-32 of its uncompressed records (rosbags writes 0, 'unchecked'),
  so a reader can tell a damaged chunk from a good one.

:class:`EpisodeBagWriter` closes the bag on every exit path: leaving its ``with`` block by an
exception still writes the summary and metadata.yaml (rosbags' own ``Writer`` would abort the
file instead).
"""

from __future__ import annotations

import json
import struct
import zlib
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import McapWriter

from mona_controller.topics import QoS, Topic
from swarm_world.messages.cdr import TYPESTORE

#: Default sim time a chunk stays open: the most a SIGKILL can lose (s).
CHUNK_PERIOD = 5.0
#: Prefix of this project's keys in the rosbag2 ``custom_data``.
CUSTOM_PREFIX = 'mona_swarm.'

# Byte offset of the uncompressed CRC inside a chunk record: opcode (1), record length (8),
# message start time (8), message end time (8), uncompressed size (8).
_CRC_OFFSET = 33
_NEVER = Qos(QosHistory.KEEP_LAST, 0, QosReliability.RELIABLE, QosDurability.VOLATILE,
             QosTime(2147483647, 4294967295), QosTime(2147483647, 4294967295),
             QosLiveliness.AUTOMATIC, QosTime(2147483647, 4294967295), False)


def offered_qos(depth: int, *, reliable: bool = True, latched: bool = False) -> Qos:
    """A QoS profile in rosbags' form, recorded with a topic so a player can offer it again."""
    return _NEVER._replace(
        depth=depth,
        reliability=QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
        durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE)


def offered(qos: QoS) -> Qos:
    """:func:`offered_qos` of a contract QoS (:class:`mona_controller.topics.QoS`)."""
    return offered_qos(qos.depth, reliable=qos.reliable, latched=qos.latched)


def bag_topics(topics: dict[str, Topic]) -> dict[str, tuple[str, Qos]]:
    """Topic -> (type, offered QoS) of contract entries, as a bag records them."""
    return {name: (topic.type, offered(topic.qos)) for name, topic in topics.items()}


class _CheckedMcapWriter(McapWriter):
    """rosbags' MCAP storage, plus chunk CRCs and a flush to the OS after every chunk."""

    def close_chunk(self) -> None:
        with self.chunk.bio.getbuffer() as records:
            crc = zlib.crc32(records)
        start = self.bio.tell()
        super().close_chunk()
        end = self.bio.tell()
        self.bio.seek(start + _CRC_OFFSET)
        self.bio.write(struct.pack('<I', crc))
        self.bio.seek(end)
        self.bio.flush()


class _Rosbag2Writer(Writer):
    STORAGE_PLUGINS = {StoragePlugin.MCAP: _CheckedMcapWriter}


class EpisodeBagWriter:
    """One episode's bag. Use as a context manager, or call :meth:`close` in ``finally``.

    Args:
        path: the bag directory to create (must not exist).
        chunk_period: sim seconds of messages one chunk may hold before it is written out.
    """

    def __init__(self, path: str | Path, *, chunk_period: float = CHUNK_PERIOD) -> None:
        self.path = Path(path)
        self.chunk_period_ns = round(chunk_period * 1e9)
        self._writer = _Rosbag2Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self._connections: dict[str, Connection] = {}
        self._chunk_start_ns: int | None = None
        self.messages = 0
        self._writer.open()
        if not isinstance(self._writer.storage, _CheckedMcapWriter):  # pragma: no cover
            raise RuntimeError('rosbags did not use the checked MCAP storage')

    @property
    def mcap_path(self) -> Path:
        """The MCAP file inside the bag directory (what Foxglove opens)."""
        return self.path / f'{self.path.name}.mcap'

    @property
    def is_open(self) -> bool:
        """False once the bag is closed."""
        return self._writer.storage is not None

    def describe(self, announcement: dict[str, Any]) -> None:
        """Keep the episode's seed and every parameter in the bag's metadata (custom_data)."""
        fields = {'episode': announcement.get('episode'), 'seed': announcement.get('seed'),
                  'population': announcement.get('population'),
                  'duration': announcement.get('duration'),
                  'start_ns': announcement.get('start_ns'),
                  'parameters': announcement.get('parameters'),
                  'plugins': announcement.get('plugins')}
        for key, value in fields.items():
            if value is not None:
                self.set_custom(key, value if isinstance(value, str) else json.dumps(value))

    def set_custom(self, key: str, value: str) -> None:
        """One ``custom_data`` entry (written to metadata.yaml and the MCAP at close)."""
        self._writer.set_custom_data(CUSTOM_PREFIX + key, value)

    def add_topic(self, topic: str, msgtype: str, qos: Sequence[Qos] = ()) -> None:
        """Register a topic (a no-op if it is known). ``msgtype`` like 'std_msgs/msg/String'."""
        if topic not in self._connections:
            self._connections[topic] = self._writer.add_connection(
                topic, msgtype, typestore=TYPESTORE,
                offered_qos_profiles=list(qos))

    def has_topic(self, topic: str) -> bool:
        """True once :meth:`add_topic` registered ``topic``."""
        return topic in self._connections

    def write(self, topic: str, log_ns: int, data: bytes | memoryview) -> None:
        """Write one serialized (CDR) message of a registered topic at sim time ``log_ns``."""
        if self._chunk_start_ns is None:
            self._chunk_start_ns = log_ns
        elif abs(log_ns - self._chunk_start_ns) >= self.chunk_period_ns:
            self.flush()
            self._chunk_start_ns = log_ns
        self._writer.write(self._connections[topic], log_ns, data)
        self.messages += 1

    def flush(self) -> None:
        """End the open chunk and hand it to the operating system (it survives a SIGKILL)."""
        storage = self._writer.storage  # checked in __init__: a _CheckedMcapWriter
        if isinstance(storage, _CheckedMcapWriter) and storage.chunk.bio.tell():
            storage.close_chunk()
        self._chunk_start_ns = None

    def close(self) -> None:
        """Write the last chunk, the summary and metadata.yaml. Safe to call twice."""
        if self._writer.storage is None:
            return
        try:
            self._writer.close()
        except BaseException:
            self._writer.abort()  # the file keeps every flushed chunk; `recover` salvages it
            raise

    def __enter__(self) -> EpisodeBagWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.close()

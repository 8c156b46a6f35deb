"""Reading episode bags (a rosbag2 directory or its .mcap file) into tables.

The MCAP file is the truth: metadata.yaml may be missing (a writer that never closed) and is
only consulted for ``custom_data``. The file is read with the strict pass of
:class:`~swarm_metrics.bags.scan.McapScan`, so every problem becomes a
:class:`~swarm_metrics.bags.scan.BagError` that says what is wrong, where, and what could be
read (:class:`~swarm_metrics.bags.scan.TruncatedBagError` for a file cut short, which
``mona-swarm recover`` salvages).

Messages are decoded with rosbags' ROS 2 Jazzy typestore, so no ROS installation is needed.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mona_controller.topics import (
    CLEANING,
    CUE_MAP,
    EPISODE,
    METRICS_PREFIX,
    POSES,
    ROBOT_STATES,
    SOURCES,
    STATUS,
)
from swarm_metrics.bags.scan import BagError, McapScan, RawMessage, ScanReport
from swarm_metrics.bags.writer import CUSTOM_PREFIX
from swarm_world.frames import poses_from_rows
from swarm_world.messages import markers as arena_markers
from swarm_world.messages.cdr import TYPESTORE
from swarm_world.timing import crossed

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


def decode_json(message: RawMessage) -> dict[str, Any]:
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
    announcement: dict[str, Any] | None = None  #: the supervisor's /episode message
    status: list[tuple[int, dict[str, Any]]] = dataclasses.field(default_factory=list)
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
            seed: int = self.announcement['seed']
            return seed
        value = self.custom.get(CUSTOM_PREFIX + 'seed')
        return int(value) if value is not None and value.isdigit() else None

    @property
    def parameters(self) -> dict[str, Any] | None:
        """Every parameter by section (from the announcement, else from custom_data)."""
        if self.announcement is not None and 'parameters' in self.announcement:
            parameters: dict[str, Any] = self.announcement['parameters']
            return parameters
        try:
            parameters = json.loads(self.custom[CUSTOM_PREFIX + 'parameters'])
            return parameters
        except (KeyError, ValueError):
            return None

    @property
    def plugins(self) -> list[Any]:
        """The plug-in records of the run (from the announcement, else from custom_data;
        none if it recorded none)."""
        if self.announcement is not None and 'parameters' in self.announcement:
            plugins: list[Any] = self.announcement.get('plugins') or []
            return plugins
        try:
            plugins = json.loads(self.custom[CUSTOM_PREFIX + 'plugins'])
            return plugins
        except (KeyError, ValueError):
            return []

    def metric(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(log times ns, values) of /metrics/<name> as recorded online."""
        rows = self.metrics.get(name, [])
        return (np.array([t for t, _ in rows], dtype=np.int64),
                np.array([v for _, v in rows], dtype=np.float64))


def _sample_ns(announcement: dict[str, Any]) -> int | None:
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
    start_ns = previous = 0  # the announcement sets them, with sample_ns
    sample_ns: int | None = None
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
                start = announcement.get('start_ns')
                if isinstance(start, int):
                    start_ns = previous = start
                    sample_ns = _sample_ns(announcement)
    bag.custom = read_custom_data(path) or scan.report.custom
    return bag

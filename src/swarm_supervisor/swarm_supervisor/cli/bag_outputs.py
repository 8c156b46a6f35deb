"""Where ``mona-swarm analyze`` reads and writes: the bag of an argument, and an output folder
that never holds the record it came from.

Without ``--out`` each bag's analysis goes into a new folder beside it, ``<bag>.analysis``
(``RUN/bag`` -> ``RUN/bag.analysis``), never into the folder holding the bag: that folder may
hold the run's own record (an embedded run's episode.json, metrics.csv and snapshots.npz),
which is the truth to compare with, not a place to write. An output folder that holds a
record is refused unless ``--overwrite`` (:mod:`swarm_supervisor.outputs.guard`), and one that
holds the bag being analysed is refused even then.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from swarm_metrics.bags.recover import SUFFIX
from swarm_metrics.bags.scan import BagError
from swarm_supervisor.outputs.guard import RecordExists, check_output, claim_output

ANALYSIS_SUFFIX = '.analysis'  #: ``<bag>.analysis``: the default output folder of a bag
BAG_NAMES = ('bag', 'bag' + SUFFIX)  # the metrics node's bag folder (and its recovered copy)


def episode_bag(path: Path) -> Path:
    """The bag an argument names: an episode folder's ``bag/`` (else its recovered copy), or
    the bag directory or .mcap itself (as ``animate`` takes them).

    Raises:
        BagError: a folder that is no bag and holds none.
    """
    path = Path(path)
    if not path.is_dir() or any(path.glob('*.mcap')) or (path / 'metadata.yaml').exists():
        return path
    for name in BAG_NAMES:
        if (path / name).is_dir():
            return path / name
    raise BagError(f'{path} holds no bag (no {path}/bag and no .mcap): record one with '
                   '`mona-swarm run --bag` or scripts/swarm.sh')


def bag_directory(path: Path) -> Path:
    """The bag itself: its rosbag2 directory, or a lone .mcap file."""
    path = path.resolve()
    if path.suffix == '.mcap' and path.parent.name == path.stem:
        return path.parent  # rosbags' layout: <dir>/<dir>.mcap
    return path


def output_folder(path: Path, out: Path | None, several: bool) -> Path:
    """Where a bag's analysis goes: ``<bag>.analysis`` beside the bag, or ``out``, or with
    several bags a subfolder of ``out`` named after the episode or bag."""
    bag = bag_directory(path)
    if out is None:
        return bag.with_name(bag.stem + ANALYSIS_SUFFIX)
    if not several:
        return out
    return out / (bag.parent.name if bag.name.startswith(BAG_NAMES) else bag.stem)


def check_outputs(bags: Sequence[Path], outs: Sequence[Path], *, overwrite: bool,
                  explicit: bool) -> None:
    """Refuse, before anything is read or written, an output folder that holds a bag being
    analysed, one that two bags would share, or one holding a record (without
    ``overwrite``).

    Raises:
        RecordExists: naming the folder and what it holds (exit status 2).
    """
    # A default folder is named as --out too: the fix is the same (another --out).
    option = '--out' if explicit else '--out (default)'
    seen: dict[Path, Path] = {}
    for bag, out in zip(bags, outs):
        inside = bag_directory(bag)
        resolved = out.resolve()
        if resolved == inside or resolved in inside.parents:
            raise RecordExists(f'{option} {out} holds the bag being analysed ({bag}): choose '
                               'another --out')
        if resolved in seen:
            raise RecordExists(f'{seen[resolved]} and {bag} would both be analysed into '
                               f'{out}: give each its own --out')
        seen[resolved] = bag
        if out.exists() and not out.is_dir():
            raise RecordExists(f'{option} {out} is a file, not a folder: choose another '
                               '--out')
        # a record there without overwrite, a writer there, a path that cannot take it
        check_output(out, overwrite=overwrite, option=option)


def claim(out: Path, *, overwrite: bool) -> Path:
    """Make ``out`` ready just before the analysis is written (checked already by
    :func:`check_outputs`): with ``overwrite`` a record there is replaced whole."""
    return claim_output(out, overwrite=overwrite)

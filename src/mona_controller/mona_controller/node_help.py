"""``--help`` of the node executables (world_node, metrics_node, supervisor_node,
mona_controller_node, live_node): a usage with the node's description, its own parameters
and its exit statuses, printed before ``rclpy.init`` so that asking starts no node.

Pure (no ROS): the lowest package holds it so that every node can use it (the layer rule).
"""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Mapping, Sequence

from mona_controller.mappings import flat_fields

#: What every node's exit status means; a node adds its own (metrics: 3, the world was lost).
STATUSES = {0: 'success (the run finished, or stopped by SIGINT / SIGTERM)',
            1: 'failed (an error, named in the log)',
            2: 'a bad parameter (named in one [FATAL] line; nothing done)'}


def own_args(argv: Sequence[str]) -> list[str]:
    """``argv`` (without the program) minus the ROS arguments: every ``--ros-args ...`` up to
    ``--`` or the end, as rclpy removes them."""
    kept: list[str] = []
    ros = False
    for arg in argv:
        if arg == '--ros-args':
            ros = True
        elif ros and arg == '--':
            ros = False
        elif not ros:
            kept.append(arg)
    return kept


def statuses_text(extra: Mapping[int, str] | None = None) -> str:
    """'exit status: 0 ..., 1 ..., 2 ...' with the node's own statuses."""
    statuses = {**STATUSES, **(extra or {})}
    return 'exit status: ' + '; '.join(f'{code} {what}' for code, what in sorted(statuses.items()))


def parameters_text(sections: Mapping[str, type]) -> str:
    """One line per parameter of the node's option dataclasses (prefix -> dataclass):
    ``-p name:=default  doc [unit]``."""
    lines = []
    for prefix, section in sections.items():
        for name, default, spec in flat_fields(section, prefix):
            unit = f' [{spec.unit}]' if spec.unit else ''
            lines.append(f'  -p {name}:={default!r}  {spec.doc}{unit}')
    return '\n'.join(lines)


def node_parser(prog: str, description: str, *, sections: Mapping[str, type] | None = None,
                statuses: Mapping[int, str] | None = None) -> argparse.ArgumentParser:
    """The argument parser of a node executable: ``--help`` (and the node's own options, added
    by the caller) before ``--ros-args``; the epilog lists the parameters and exit statuses."""
    epilog = ['ROS arguments follow --ros-args: --params-file FILE (e.g. ros_ws/config/'
              'mona_swarm.yaml, the model parameters) and -p NAME:=VALUE.']
    if sections:
        epilog.append("The node's own parameters (default, meaning):\n" +
                      parameters_text(sections))
    epilog.append(textwrap.fill(statuses_text(statuses) + '.', 92))
    return argparse.ArgumentParser(prog=prog, description=description,
                                   epilog='\n\n'.join(epilog), allow_abbrev=False,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)


def parse_node_args(parser: argparse.ArgumentParser,
                    argv: Sequence[str]) -> argparse.Namespace:
    """Parse the node's own arguments of ``argv`` (without the program; ROS arguments are
    skipped). ``--help`` prints the usage and exits 0; a bad option exits 2."""
    return parser.parse_args(own_args(argv))

"""The public faces of the packages (an ``__init__`` with ``__all__`` and
:func:`mona_controller.exports.lazy_exports`): importing every face imports none of the
modules behind it, nor a heavy library, and every name a face lists is found where it says."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / 'src'
PACKAGES = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor')
#: What a face must not import by itself: the compiled, graphical and ROS libraries.
HEAVY = {'numpy', 'numba', 'pymunk', 'rclpy', 'rosbags', 'mcap', 'pandas', 'matplotlib'}


def faces() -> list[str]:
    """Every package whose ``__init__`` is a lazy face, by dotted name."""
    return [
        '.'.join(init.parent.relative_to(SRC / package).parts)
        for package in PACKAGES for init in sorted((SRC / package / package).rglob('__init__.py'))
        if 'lazy_exports(' in init.read_text()]


FACES = faces()
#: Importing every face, then looking every listed name up, in a fresh interpreter.
SCRIPT = """
import importlib, json, sys
names = sys.argv[1:]
before = set(sys.modules)
faces = [importlib.import_module(name) for name in names]
loaded = sorted(set(sys.modules) - before)
missing = [f"{face.__name__}.{name}" for face in faces for name in face.__all__
           if not hasattr(face, name)]
unsorted = [face.__name__ for face in faces if face.__all__ != sorted(dir(face))]
print(json.dumps({"loaded": loaded, "missing": missing, "unsorted": unsorted}))
"""


def test_the_lower_packages_have_faces():
    expected = {'swarm_world', 'swarm_world.sensing', 'swarm_world.messages',
                'swarm_world.driver', 'swarm_world.ros', 'swarm_metrics', 'swarm_metrics.bags',
                'swarm_metrics.ros'}
    assert expected <= set(FACES), expected - set(FACES)


def test_a_face_imports_nothing_behind_it_and_every_name_resolves():
    done = subprocess.run([sys.executable, '-c', SCRIPT, *FACES], capture_output=True,
                          text=True, timeout=300, check=True)
    found = json.loads(done.stdout)
    parents = {face.rpartition('.')[0] for face in FACES}
    behind = [name for name in found['loaded']
              if name.split('.')[0] in HEAVY or name.split('.')[0] in PACKAGES
              and name not in FACES and name not in parents and name not in PACKAGES
              and not name.endswith('.exports')]
    assert behind == [], behind
    assert found['missing'] == [] and found['unsorted'] == [], found


def test_the_old_names_of_the_moved_adapters_forward_for_one_release():
    from mona_controller.ros import qos
    from swarm_supervisor.system.ros import supervisor_node
    with pytest.warns(DeprecationWarning, match='mona_controller.qos.POSES_QOS moved to '
                                                'mona_controller.ros.qos.POSES_QOS'):
        from mona_controller.qos import POSES_QOS
    assert POSES_QOS is qos.POSES_QOS
    with pytest.warns(DeprecationWarning, match='system.ros.supervisor_node.Supervisor'):
        from swarm_supervisor.system.supervisor_node import Supervisor
    assert Supervisor is supervisor_node.Supervisor


def test_the_names_that_left_the_schema_forward_for_one_release():
    from mona_controller import mappings, schema
    with pytest.warns(DeprecationWarning, match='mona_controller.schema.from_mapping moved to '
                                                'mona_controller.mappings.from_mapping'):
        from mona_controller.schema import from_mapping
    assert from_mapping is mappings.from_mapping
    with pytest.raises(AttributeError):
        schema.no_such_name  # noqa: B018


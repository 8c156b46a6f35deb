"""The import layers of the four packages, read from their source (an AST walk, no imports).

- The packages depend one way: mona_controller <- swarm_world <- swarm_metrics <-
  swarm_supervisor.
- swarm_supervisor's sub-packages are layered (:data:`SUPERVISOR_LAYERS`): a module imports
  only from its own sub-package and the layers below it; siblings of a layer never import each
  other, and nothing imports the CLI.
- No import cycle anywhere in src, counting every import (also those inside functions and
  those under ``if TYPE_CHECKING:``, for annotations only: two modules that name each other
  even there cannot be read apart).
- The pure cores import no ROS: only the adapters (:data:`ADAPTERS`) and the CLI above them
  import rclpy or a message package, and no pure module imports an adapter.
- No module uses another module's private name (``from x import _y``, ``x._y``).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / 'src'
#: The packages, bottom first: each may import only those before it.
PACKAGES = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor')
#: swarm_supervisor's layers, bottom first; the names of one layer are siblings.
SUPERVISOR_LAYERS = (('config', 'exits', 'exports'), ('engine',), ('outputs', 'envs'), ('media',),
                     ('study',), ('analysis', 'system'), ('calibration', 'evolution'),
                     ('cli',))
#: The ROS adapters: the modules that may import rclpy and the message packages.
ADAPTERS = {
    'mona_controller.controller_node', 'mona_controller.messages', 'mona_controller.qos',
    'mona_controller.ros_params', 'mona_controller.shutdown',
    'swarm_world.world_node', 'swarm_world.world_messages',
    'swarm_world.driver.driver_node', 'swarm_world.driver.hil', 'swarm_world.driver.hil_tracker',
    'swarm_metrics.metrics_node',
    'swarm_supervisor.system.supervisor_node', 'swarm_supervisor.system.live_node',
    'swarm_supervisor.system.replay',
}
#: The link to real robots (docs/link.md): pure, shared by a driver and its tests, so it
#: imports nothing of ours outside itself (the frame codec runs where no model does).
LINK = {'mona_controller.link', 'mona_controller.link.crc', 'mona_controller.link.frame',
        'mona_controller.link.payloads', 'mona_controller.link.sequence',
        'mona_controller.link.transport'}
#: Top-level modules of ROS itself (and the message packages, by their suffix).
ROS = {'rclpy', 'rosidl_runtime_py', 'rosidl_parser', 'builtin_interfaces', 'rosgraph_msgs'}


def module_files() -> dict[str, Path]:
    """Every module of the four packages by dotted name (a package by its own name)."""
    modules = {}
    for package in PACKAGES:
        root = SRC / package
        for path in sorted((root / package).rglob('*.py')):
            parts = path.relative_to(root).with_suffix('').parts
            if parts[-1] == '__init__':
                parts = parts[:-1]
            modules['.'.join(parts)] = path
    return modules


MODULES = module_files()


def typing_only(tree: ast.Module) -> set[ast.AST]:
    """The import statements under ``if TYPE_CHECKING:``: names for annotations, never
    imported when the program runs, so no edge of its import graph."""
    hidden = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and 'TYPE_CHECKING' in ast.unparse(node.test):
            hidden |= {inner for statement in node.body for inner in ast.walk(statement)}
    return hidden


def imports(name: str, annotations: bool = False) -> Iterator[tuple[str, int]]:
    """(imported module, line) of every import in module ``name`` (those only for
    annotations too if ``annotations``), resolved to a module or package of ours where it
    names one, else the top-level name imported."""
    tree = ast.parse(MODULES[name].read_text())
    package = name if MODULES[name].name == '__init__.py' else name.rpartition('.')[0]
    hidden = set() if annotations else typing_only(tree)
    for node in ast.walk(tree):
        if node in hidden:
            continue
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:  # relative: from the package of this module
                parent = package.split('.')[:len(package.split('.')) - node.level + 1]
                base = '.'.join(parent + ([base] if base else []))
            for alias in node.names:
                candidate = f'{base}.{alias.name}'
                yield (candidate if candidate in MODULES else base), node.lineno


def ours(module: str) -> str | None:
    """The module of ours that ``module`` is or lies in (None for a library)."""
    while module and module not in MODULES:
        module = module.rpartition('.')[0]
    return module or None


def edges(annotations: bool = False) -> dict[str, set[str]]:
    """Module -> the modules of ours it imports (also for annotations only, if
    ``annotations``)."""
    graph = {}
    for name in MODULES:
        graph[name] = {target for imported, _ in imports(name, annotations)
                       if (target := ours(imported)) is not None and target != name}
    return graph


def is_ros(module: str) -> bool:
    top = module.split('.')[0]
    return top in ROS or top.endswith('_msgs')


def supervisor_layer(module: str) -> tuple[int, str]:
    """(layer index, sub-package or module) of a swarm_supervisor module."""
    part = module.split('.')[1] if '.' in module else 'config'
    for index, names in enumerate(SUPERVISOR_LAYERS):
        if part in names:
            return index, part
    raise AssertionError(f'{module}: swarm_supervisor.{part} is in no layer of '
                         'SUPERVISOR_LAYERS; add it where it belongs')


def pure(module: str) -> bool:
    return module not in ADAPTERS and not module.startswith('swarm_supervisor.cli')


def test_every_adapter_exists():
    assert ADAPTERS <= set(MODULES), ADAPTERS - set(MODULES)


def test_the_link_is_pure_and_self_contained():
    assert LINK <= set(MODULES), LINK - set(MODULES)
    graph = edges()
    wrong = [f'{name} imports {target}' for name in LINK for target in graph[name]
             if target not in LINK]
    assert not wrong and all(pure(name) for name in LINK), wrong


def test_packages_depend_one_way():
    wrong = [f'{source} imports {target}' for source, targets in edges().items()
             for target in targets
             if PACKAGES.index(target.split('.')[0]) > PACKAGES.index(source.split('.')[0])]
    assert not wrong, wrong


def test_supervisor_layers_point_down():
    wrong = []
    for source, targets in edges().items():
        if not source.startswith('swarm_supervisor'):
            continue
        layer, part = supervisor_layer(source)
        for target in targets:
            if not target.startswith('swarm_supervisor') or target == 'swarm_supervisor':
                continue
            other_layer, other = supervisor_layer(target)
            if other != part and other_layer >= layer:
                wrong.append(f'{source} ({part}) imports {target} ({other})')
    assert not wrong, wrong


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """The cycles of ``graph``: its strongly connected components of more than one module
    (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph.get(node, ()):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_no_import_cycle():
    assert strongly_connected(edges(annotations=True)) == []


def test_the_cycle_finder_finds_a_cycle():
    assert strongly_connected({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}) == [
        ['a', 'b', 'c']]


def test_pure_cores_import_no_ros():
    wrong = []
    for name in MODULES:
        if not pure(name):
            continue
        for imported, line in imports(name):
            if is_ros(imported) or ours(imported) in ADAPTERS:
                wrong.append(f'{MODULES[name].relative_to(SRC)}:{line} imports {imported}')
    assert not wrong, wrong


def private_uses(name: str) -> Iterator[str]:
    """Where module ``name`` uses a private name of another module of ours."""
    tree = ast.parse(MODULES[name].read_text())
    aliases = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if ours(alias.name) == alias.name:
                    aliases[alias.asname or alias.name] = alias.name
        elif isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                target = f'{node.module}.{alias.name}'
                if target in MODULES:
                    aliases[alias.asname or alias.name] = target
                elif ours(node.module) and _private(alias.name):
                    yield f'line {node.lineno}: from {node.module} import {alias.name}'
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                and node.value.id in aliases and _private(node.attr)):
            yield f'line {node.lineno}: {node.value.id}.{node.attr}'


def _private(name: str) -> bool:
    return name.startswith('_') and not (name.startswith('__') and name.endswith('__'))


@pytest.mark.parametrize('name', sorted(MODULES))
def test_no_module_uses_another_modules_private_names(name):
    assert list(private_uses(name)) == []

"""The import layers of the four packages, read from their source (an AST walk, no imports).

- The packages depend one way: mona_controller <- swarm_world <- swarm_metrics <-
  swarm_supervisor.
- swarm_supervisor's sub-packages are layered (:data:`SUPERVISOR_LAYERS`): a module imports
  only from its own sub-package and the layers below it; siblings of a layer never import each
  other, and nothing imports the CLI.
- No import cycle anywhere in src, counting every import (also those inside functions and
  those under ``if TYPE_CHECKING:``, for annotations only: two modules that name each other
  even there cannot be read apart).
- The pure cores import no ROS, by a folder rule: a ROS adapter is a module under a ``ros``
  folder (``mona_controller.ros``, ``swarm_world.ros``, ``swarm_metrics.ros``,
  ``swarm_supervisor.system.ros``), and only those import ROS (:func:`is_ros`: rclpy, the
  message and interface packages, rosidl, launch). No other module imports ROS or an adapter;
  the CLI above every layer imports the adapters only inside its functions, where the command
  needs them.
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
SUPERVISOR_LAYERS = (('yaml_text',), ('config', 'exits', 'exports'), ('engine',), ('outputs',),
                     ('media',), ('envs', 'study'), ('analysis', 'system'),
                     ('calibration', 'evolution'), ('cli',))
#: The link to real robots (docs/link.md): pure, shared by a driver and its tests, so it
#: imports nothing of ours outside itself (the frame codec runs where no model does).
LINK = {'mona_controller.link', 'mona_controller.link.crc', 'mona_controller.link.frame',
        'mona_controller.link.payloads', 'mona_controller.link.sequence',
        'mona_controller.link.transport'}
#: Top-level modules of ROS itself: the client library and what stands beside it in a ROS
#: installation (the rest by their prefix or suffix, :func:`is_ros`).
ROS = {'rclpy', 'rcl', 'rmw', 'rpyutils', 'launch', 'launch_ros', 'ament_index_python',
       'rosbag2_py', 'message_filters', 'builtin_interfaces'}
#: Prefixes and suffixes of the generated message packages and ROS libraries (std_msgs,
#: rcl_interfaces, std_srvs, rosidl_runtime_py, tf2_ros, ...).
ROS_PREFIXES = ('rosidl_', 'rcl_', 'rmw_', 'tf2')
ROS_SUFFIXES = ('_msgs', '_srvs', '_interfaces')


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
    """Whether ``module`` (an imported name) is part of ROS: it needs a ROS installation."""
    top = module.split('.')[0]
    return top in ROS or top.startswith(ROS_PREFIXES) or top.endswith(ROS_SUFFIXES)


def supervisor_layer(module: str) -> tuple[int, str]:
    """(layer index, sub-package or module) of a swarm_supervisor module."""
    part = module.split('.')[1] if '.' in module else 'config'
    for index, names in enumerate(SUPERVISOR_LAYERS):
        if part in names:
            return index, part
    raise AssertionError(f'{module}: swarm_supervisor.{part} is in no layer of '
                         'SUPERVISOR_LAYERS; add it where it belongs')


def adapter(module: str) -> bool:
    """Whether ``module`` is a ROS adapter: it lies in a ``ros`` folder of its package."""
    return 'ros' in module.split('.')[1:]


def pure(module: str) -> bool:
    return not adapter(module) and not module.startswith('swarm_supervisor.cli')


def test_every_package_keeps_its_adapters_in_a_ros_folder():
    folders = {name for name in MODULES if name.split('.')[-1] == 'ros'}
    assert folders == {'mona_controller.ros', 'swarm_world.ros', 'swarm_metrics.ros',
                       'swarm_supervisor.system.ros'}, folders
    # Each holds adapters indeed: every module of a ros folder but its face imports ROS.
    idle = [name for name in MODULES if adapter(name) and name not in folders
            and not any(is_ros(imported) for imported, _ in imports(name))
            and not any(adapter(target) for target in edges()[name])]
    assert not idle, f'modules of a ros folder that import no ROS: {idle}'


def test_the_ros_rule_knows_the_ros_packages():
    assert all(map(is_ros, ('rclpy.node', 'std_msgs.msg', 'geometry_msgs', 'rosgraph_msgs',
                            'builtin_interfaces.msg', 'rcl_interfaces.msg', 'std_srvs.srv',
                            'rosidl_runtime_py', 'launch_ros.actions', 'tf2_ros')))
    assert not any(map(is_ros, ('rosbags.typesys', 'mcap_ros2.decoder', 'numpy', 'json',
                                'swarm_world.ros', 'mona_controller.messages')))


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


def test_only_ros_folders_import_ros():
    """Every import, also one inside a function: a module outside a ros folder imports
    neither ROS nor an adapter; only the CLI, above every layer, imports an adapter (inside
    the function of the command that needs it, so the CLI starts without ROS)."""
    wrong = []
    for name in MODULES:
        if adapter(name):
            continue
        cli = name.startswith('swarm_supervisor.cli')
        for imported, line in imports(name, annotations=True):
            if is_ros(imported) or (adapter(ours(imported) or '') and not cli):
                wrong.append(f'{MODULES[name].relative_to(SRC)}:{line} imports {imported}')
    assert not wrong, wrong


def test_the_cli_imports_adapters_only_inside_functions():
    wrong = []
    for name in MODULES:
        if not name.startswith('swarm_supervisor.cli'):
            continue
        tree = ast.parse(MODULES[name].read_text())
        for node in tree.body:
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                         else [node.module or ''])
                wrong += [f'{name}:{node.lineno} imports {module}' for module in names
                          if adapter(ours(module) or '')]
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

"""The arena: its walls and any static obstacles, as one list of shapes. Pure (no ROS).

The arena is the square [0, side]^2 closed by four walls (:class:`Walls`). Obstacles inside
it come from ``world.obstacles``, a mapping of names to ``[kind, numbers...]`` (m):

- ``disc``: ``[x, y, radius]``, a pillar (:class:`Disc`);
- ``rect``: ``[x0, y0, x1, y1]``, an axis-aligned rectangle from its lower-left to its
  upper-right corner (:class:`Rect`);
- ``polygon``: ``[x1, y1, x2, y2, x3, y3, ...]``, a **convex** polygon with its vertices in
  either order (:class:`Polygon`). Convex only: the inside test below and pymunk's ``Poly``
  (the convex hull of its vertices) rely on it. A non-convex obstacle is a union of convex
  ones: obstacles may overlap.

The kind may be left out (``[x, y, radius]``): 3 numbers are a disc, 4 a rect, 6 or more a
polygon. A ROS parameter file cannot mix strings and numbers in one list (rcl refuses it:
"Sequence should be of same type"), so a file that both runners read spells obstacles so.

Every module that needs the arena's geometry takes it from here: :mod:`swarm_world.physics`
makes static pymunk shapes of the obstacles, :mod:`swarm_world.sensing.ir` casts the IR
beams against the flat arrays of :func:`pack` (one ray test per kind,
:mod:`swarm_world.sensing.rays`: the walls, a disc, a segment for each edge of a rect or
polygon), :mod:`swarm_world.placement` keeps robots clear of them
by :meth:`clearance`, and :mod:`swarm_world.field` may clear the cue under them.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from mona_controller.schema import ParameterError

#: Source and obstacle names become metrics columns and topic names: lower-case identifiers.
NAME_PATTERN = re.compile(r'^[a-z][a-z0-9_]*$')
#: What the IR kernel casts a beam against (``ObstacleArrays.kinds``).
DISC_RAYS, SEGMENT_RAYS = 0, 1


@dataclasses.dataclass(frozen=True)
class Walls:
    """The arena's four walls: the floor is the square [0, side]^2 inside them (m)."""

    side: float
    kind = 'walls'

    def clearance(self, x: float, y: float) -> float:
        """How far the point (m) is from the nearest wall, negative beyond it."""
        return min(x, y, self.side - x, self.side - y)


@dataclasses.dataclass(frozen=True)
class Disc:
    """A round obstacle (a pillar): centre (x, y) and radius, m."""

    name: str
    x: float
    y: float
    radius: float
    kind = 'disc'

    def clearance(self, x: float, y: float) -> float:
        """How far the point (m) is from the disc, negative inside it."""
        return math.hypot(x - self.x, y - self.y) - self.radius

    @property
    def box(self) -> tuple[float, float, float, float]:
        """The bounding box (x0, y0, x1, y1), m."""
        return (self.x - self.radius, self.y - self.radius, self.x + self.radius,
                self.y + self.radius)

    @property
    def area(self) -> float:
        """The floor it covers (m^2)."""
        return math.pi * self.radius ** 2

    def covers(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Whether each point (arrays of m, broadcast together) is in the disc or on it."""
        return (xs - self.x) ** 2 + (ys - self.y) ** 2 <= self.radius ** 2

    def rays(self) -> tuple[int, list[tuple[float, float, float, float]]]:
        """What the IR kernel casts against: (DISC_RAYS, [(x, y, radius, 0)])."""
        return DISC_RAYS, [(self.x, self.y, self.radius, 0.0)]


@dataclasses.dataclass(frozen=True)
class Polygon:
    """A convex polygon, its vertices (m) counter-clockwise."""

    name: str
    vertices: tuple[tuple[float, float], ...]
    kind = 'polygon'

    @property
    def edges(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        """The edges (a, b), counter-clockwise, the last one closing the loop."""
        return list(zip(self.vertices, self.vertices[1:] + self.vertices[:1]))

    def clearance(self, x: float, y: float) -> float:
        """How far the point (m) is from the polygon, negative inside it."""
        distance = min(_segment_distance(x, y, *a, *b) for a, b in self.edges)
        return -distance if self._inside(x, y) else distance

    def _inside(self, x: float, y: float) -> bool:
        # Convex and counter-clockwise: inside (or on it) is left of (or on) every edge.
        return all((bx - ax) * (y - ay) - (by - ay) * (x - ax) >= 0.0
                   for (ax, ay), (bx, by) in self.edges)

    @property
    def box(self) -> tuple[float, float, float, float]:
        """The bounding box (x0, y0, x1, y1), m."""
        xs, ys = zip(*self.vertices)
        return (min(xs), min(ys), max(xs), max(ys))

    @property
    def area(self) -> float:
        """The floor it covers (m^2)."""
        return _signed_area(self.vertices)

    def covers(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Whether each point (arrays of m, broadcast together) is in the polygon or on it."""
        inside = np.ones(np.broadcast_shapes(np.shape(xs), np.shape(ys)), dtype=bool)
        for (ax, ay), (bx, by) in self.edges:
            inside &= (bx - ax) * (ys - ay) - (by - ay) * (xs - ax) >= 0.0
        return inside

    def rays(self) -> tuple[int, list[tuple[float, float, float, float]]]:
        """What the IR kernel casts against: (SEGMENT_RAYS, [(ax, ay, bx, by)] per edge)."""
        return SEGMENT_RAYS, [(ax, ay, bx, by) for (ax, ay), (bx, by) in self.edges]


@dataclasses.dataclass(frozen=True)
class Rect(Polygon):
    """An axis-aligned rectangle: a polygon of four vertices (see :meth:`of`)."""

    kind = 'rect'

    @classmethod
    def of(cls, name: str, x0: float, y0: float, x1: float, y1: float) -> Rect:
        """The rectangle from corner (x0, y0) to corner (x1, y1), m (x0 < x1, y0 < y1)."""
        return cls(name, ((x0, y0), (x1, y0), (x1, y1), (x0, y1)))


Obstacle = Disc | Polygon  # a Rect is a Polygon


class ObstacleArrays(NamedTuple):
    """The obstacles of E arenas as the IR kernel takes them (:func:`pack`).

    Obstacle m has bounding box ``boxes[m]`` (x0, y0, x1, y1), ray kind ``kinds[m]``
    (:data:`DISC_RAYS` or :data:`SEGMENT_RAYS`) and rows ``geometry[first[m]:first[m + 1]]``:
    one (x, y, radius, 0) for a disc, one (ax, ay, bx, by) per edge otherwise. Arena e holds
    obstacles ``bounds[e]:bounds[e + 1]``.
    """

    boxes: np.ndarray  #: [M, 4] float64
    kinds: np.ndarray  #: [M] int64
    first: np.ndarray  #: [M + 1] int64
    geometry: np.ndarray  #: [G, 4] float64
    bounds: np.ndarray  #: [E + 1] int64


def pack(arenas: Sequence[Arena]) -> ObstacleArrays:
    """The obstacles of ``arenas``, arena after arena, in flat arrays (one call of the IR
    kernel takes a whole batch's)."""
    boxes, kinds, first, geometry, bounds = [], [], [0], [], [0]
    for arena in arenas:
        for obstacle in arena.obstacles:
            kind, rows = obstacle.rays()
            boxes.append(obstacle.box)
            kinds.append(kind)
            geometry.extend(rows)
            first.append(len(geometry))
        bounds.append(len(boxes))
    return ObstacleArrays(np.array(boxes, dtype=np.float64).reshape(-1, 4),
                          np.array(kinds, dtype=np.int64), np.array(first, dtype=np.int64),
                          np.array(geometry, dtype=np.float64).reshape(-1, 4),
                          np.array(bounds, dtype=np.int64))


@dataclasses.dataclass(frozen=True)
class Arena:
    """The walled square of side ``side`` (m) and the obstacles in it, in name order."""

    side: float
    obstacles: tuple[Obstacle, ...] = ()

    @property
    def shapes(self) -> tuple[Walls | Obstacle, ...]:
        """The walls, then the obstacles: everything a robot cannot enter."""
        return (Walls(self.side), *self.obstacles)

    def clearance(self, x: float, y: float) -> float:
        """How far the point (m) is from the nearest wall or obstacle, negative in one."""
        return min(shape.clearance(x, y) for shape in self.shapes)

    @property
    def floor_area(self) -> float:
        """The floor left by the obstacles (m^2; overlapping obstacles are counted twice,
        so never more than the free floor)."""
        return self.side ** 2 - sum(obstacle.area for obstacle in self.obstacles)

    @functools.cached_property
    def packed(self) -> ObstacleArrays:
        """:func:`pack` of this arena alone (what ``ir.proximity`` takes)."""
        return pack([self])

    def under(self, cells: int, cell_size: float) -> np.ndarray:
        """[cells, cells] bool (row = y cell): the cells whose centre an obstacle covers."""
        centres = (np.arange(cells) + 0.5) * cell_size
        xs, ys = centres[None, :], centres[:, None]
        under = np.zeros((cells, cells), dtype=bool)
        for obstacle in self.obstacles:
            under |= obstacle.covers(xs, ys)
        return under


#: The numbers each kind takes (None: a polygon, 3 or more (x, y) pairs).
COUNTS = {'disc': 3, 'rect': 4, 'polygon': None}


def parse_obstacles(given: Sequence[tuple[str, tuple[Any, ...]]], side: float,
                    sources: Sequence[tuple[str, float, float]] = (),
                    prefix: str = 'world.obstacles.') -> tuple[Obstacle, ...]:
    """The obstacles of ``world.obstacles`` (name, values) pairs, in name order.

    Args:
        given: (name, [kind, numbers...]) pairs; the kind may be left out (see the module).
        side: the arena side (m): every obstacle lies inside the arena.
        sources: (name, x, y) of the leak sources: no obstacle may cover a source's centre.
        prefix: what an error names before the obstacle's name (a layout's obstacles are
            named by the layout).

    Returns:
        The obstacles, sorted by name.

    Raises:
        ParameterError: naming the key (``world.obstacles.<name>``): a bad name, an unknown
            kind, a wrong count, a point outside the arena, a degenerate or non-convex shape,
            or a source's centre covered.
    """
    obstacles = []
    for name, values in sorted(given):
        where = f'{prefix}{name}'
        if not NAME_PATTERN.match(name):
            raise ParameterError(f'{where}: an obstacle name must be a lower-case identifier')
        obstacle = _parse(where, name, tuple(values), side)
        for source, x, y in sources:
            if obstacle.clearance(x, y) <= 0.0:
                raise ParameterError(f'{where}: covers the centre ({x}, {y}) of source '
                                     f'{source!r}')
        obstacles.append(obstacle)
    return tuple(obstacles)


def _parse(where: str, name: str, values: tuple[Any, ...], side: float) -> Obstacle:
    """One obstacle from [kind, numbers...] or [numbers...]."""
    if values and isinstance(values[0], str):
        kind, numbers = values[0], values[1:]
        if kind not in COUNTS:
            raise ParameterError(f'{where}: unknown kind {kind!r} (kinds: '
                                 f'{", ".join(COUNTS)})')
    else:
        numbers = values
        kind = {3: 'disc', 4: 'rect'}.get(len(numbers), 'polygon')
    if any(isinstance(v, (bool, str)) for v in numbers):
        raise ParameterError(f'{where} = {list(values)}: expected [kind, numbers...]')
    count = COUNTS[kind]
    if (len(numbers) != count if count else len(numbers) < 6 or len(numbers) % 2):
        expected = f'{count} numbers' if count else 'x, y pairs of 3 or more vertices'
        raise ParameterError(f'{where} = {list(values)}: a {kind} takes {expected}')
    numbers = tuple(float(v) for v in numbers)
    if not all(math.isfinite(v) for v in numbers):
        raise ParameterError(f'{where} = {list(values)}: expected finite numbers')
    if kind == 'disc':
        x, y, radius = numbers
        if radius <= 0.0:
            raise ParameterError(f'{where}: a disc of radius {radius} m is degenerate')
        points = [(x - radius, y - radius), (x + radius, y + radius)]
        shape: Obstacle = Disc(name, x, y, radius)
    elif kind == 'rect':
        x0, y0, x1, y1 = numbers
        if not (x0 < x1 and y0 < y1):
            raise ParameterError(f'{where}: a rect is [x0, y0, x1, y1] with x0 < x1 and '
                                 f'y0 < y1 (got {list(numbers)})')
        points = [(x0, y0), (x1, y1)]
        shape = Rect.of(name, x0, y0, x1, y1)
    else:
        points = list(zip(numbers[::2], numbers[1::2]))
        shape = Polygon(name, _convex(where, points))
    for x, y in points:
        if not (0.0 <= x <= side and 0.0 <= y <= side):
            raise ParameterError(f'{where}: the point ({x}, {y}) is outside the {side} m '
                                 'arena')
    return shape


def _convex(where: str, points: list[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """The vertices counter-clockwise, if they make a convex polygon; else an error."""
    turns, crosses = 0.0, []
    for k, (bx, by) in enumerate(points):
        ax, ay = points[k - 1]
        cx, cy = points[(k + 1) % len(points)]
        ex, ey, fx, fy = bx - ax, by - ay, cx - bx, cy - by
        if (ex, ey) == (0.0, 0.0):
            raise ParameterError(f'{where}: the polygon repeats the vertex ({ax}, {ay}) '
                                 '(degenerate)')
        cross = ex * fy - ey * fx
        crosses.append(cross)
        turns += math.atan2(cross, ex * fx + ey * fy)
    # Convex: every corner turns the same way, and the boundary goes round once (a star's
    # corners all turn one way too, but it winds twice).
    one_way = all(c > 0.0 for c in crosses) or all(c < 0.0 for c in crosses)
    if one_way and abs(abs(turns) - 2.0 * math.pi) < 1e-6:
        return tuple(points) if crosses[0] > 0.0 else tuple(reversed(points))
    if not one_way and (all(c >= 0.0 for c in crosses) or all(c <= 0.0 for c in crosses)):
        raise ParameterError(f'{where}: the polygon has three vertices in a line '
                             '(degenerate); leave the middle one out')
    raise ParameterError(f'{where}: the polygon is not convex (or crosses itself); give a '
                         'non-convex obstacle as several convex ones')


def _signed_area(vertices: Sequence[tuple[float, float]]) -> float:
    """The shoelace area (m^2), positive for counter-clockwise vertices."""
    loop = list(zip(vertices, list(vertices[1:]) + list(vertices[:1])))
    return 0.5 * sum(ax * by - bx * ay for (ax, ay), (bx, by) in loop)


def _segment_distance(px: float, py: float, ax: float, ay: float, bx: float,
                      by: float) -> float:
    """The distance from point p to the segment ab (m)."""
    ex, ey = bx - ax, by - ay
    length_sq = ex * ex + ey * ey
    f = 0.0 if length_sq == 0.0 else min(max(((px - ax) * ex + (py - ay) * ey) / length_sq,
                                             0.0), 1.0)
    return math.hypot(px - ax - f * ex, py - ay - f * ey)

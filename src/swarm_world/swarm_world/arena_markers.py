"""The arena's obstacles and the leak sources as marker data, and back. Pure (no ROS).

``/world/obstacles`` (docs/interfaces.md) is a ``visualization_msgs/MarkerArray`` with one
marker per obstacle of :class:`swarm_world.arena.Arena`, in name order: namespace
:data:`NAMESPACE`, id = the obstacle's index in name order (stable for a layout), the
obstacle's name in ``text``, frame ``world`` (REP 103), stamp 0 (static scenery: valid at any
time, as RViz and Foxglove take it), grey (:data:`COLOUR`), :data:`HEIGHT` tall:

- a disc is a ``CYLINDER`` at its centre, ``scale`` (2 r, 2 r, height);
- a rect a ``CUBE`` at its centre, ``scale`` (width, depth, height);
- a polygon a ``TRIANGLE_LIST`` prism in world coordinates (identity pose, unit scale): first
  its top face as a fan from its first vertex (n - 2 triangles, counter-clockwise seen from
  above), then two triangles per side wall (2 n), so 3 n - 2 triangles for n vertices.

:func:`obstacle_markers` makes the markers; the world node
(:func:`swarm_world.world_messages.obstacle_markers`) and the embedded runner
(:func:`swarm_metrics.world_cdr.obstacles_cdr`) build their messages from it, so both
publish and record the same. :func:`obstacles_from_markers` turns decoded markers (rclpy's,
rosbags', mcap-ros2-support's: anything with the message's fields) back into shapes, for the
videos.

``/world/sources`` (also a ``visualization_msgs/MarkerArray``) shows where the leak sources
are at a sim time: one ``SPHERE`` per source in name order, namespace
:data:`SOURCES_NAMESPACE`, id = its index, its name in ``text``, :data:`SOURCE_SIZE` across,
resting on the floor at the source's centre, magenta (:data:`SOURCE_COLOUR`: neither the
cue's greys nor a robot state's colour); every marker is stamped with the time it shows.
:func:`source_markers` makes them for both runners, :func:`sources_from_markers` reads them
back.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from mona_controller.contract import WORLD_FRAME
from swarm_world.arena import Arena, Disc, Obstacle, Polygon, Rect

NAMESPACE = 'obstacles'
#: The drawn height of an obstacle (m): taller than a robot's marker (5 cm).
HEIGHT = 0.1
#: RGBA of every obstacle: the grey the videos fill them with.
COLOUR = (0.5, 0.5, 0.5, 1.0)
FRAME = WORLD_FRAME
#: visualization_msgs/Marker's type and action codes used here.
CUBE, SPHERE, CYLINDER, TRIANGLE_LIST = 1, 2, 3, 11
ADD = 0
SOURCES_NAMESPACE = 'sources'
#: The drawn diameter of a source's sphere (m): about a Mona's size, small beside any disc.
SOURCE_SIZE = 0.08
#: RGBA of every source marker.
SOURCE_COLOUR = (0.85, 0.0, 0.85, 1.0)

Point = tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class MarkerData:
    """The fields of one obstacle's marker that vary (the rest: see the module)."""

    id: int
    type: int  #: :data:`CUBE`, :data:`CYLINDER` or :data:`TRIANGLE_LIST`
    position: Point  #: the pose's position (m); the orientation is the identity
    scale: Point
    points: tuple[Point, ...] = ()  #: a triangle list's corners, three per triangle
    text: str = ''  #: the obstacle's name


def obstacle_markers(arena: Arena) -> tuple[MarkerData, ...]:
    """One marker per obstacle of ``arena``, in name order (id = index)."""
    return tuple(_marker(k, obstacle) for k, obstacle in enumerate(arena.obstacles))


def _marker(index: int, obstacle: Obstacle) -> MarkerData:
    if isinstance(obstacle, Disc):
        return MarkerData(index, CYLINDER, (obstacle.x, obstacle.y, HEIGHT / 2),
                          (2 * obstacle.radius, 2 * obstacle.radius, HEIGHT), text=obstacle.name)
    if isinstance(obstacle, Rect):
        x0, y0, x1, y1 = obstacle.box
        return MarkerData(index, CUBE, ((x0 + x1) / 2, (y0 + y1) / 2, HEIGHT / 2),
                          (x1 - x0, y1 - y0, HEIGHT), text=obstacle.name)
    return MarkerData(index, TRIANGLE_LIST, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0),
                      prism(obstacle.vertices), text=obstacle.name)


def prism(vertices: tuple[tuple[float, float], ...]) -> tuple[Point, ...]:
    """A convex polygon (vertices counter-clockwise) as a triangle list of a prism from z = 0
    to :data:`HEIGHT`: the top face, a fan from the first vertex, then the side walls."""
    top = [(x, y, HEIGHT) for x, y in vertices]
    points: list[Point] = []
    for k in range(1, len(top) - 1):
        points += [top[0], top[k], top[k + 1]]
    for (ax, ay), (bx, by) in zip(vertices, vertices[1:] + vertices[:1]):
        # Outward-facing (counter-clockwise seen from outside).
        points += [(ax, ay, 0.0), (bx, by, 0.0), (bx, by, HEIGHT),
                   (ax, ay, 0.0), (bx, by, HEIGHT), (ax, ay, HEIGHT)]
    return tuple(points)


def obstacles_from_markers(markers: Iterable[object]) -> tuple[Obstacle, ...]:
    """The obstacles that decoded ``/world/obstacles`` markers show, in the markers' order.

    Markers of another namespace, another action than ADD or another type are left out. A
    cube's corners are its centre -+ half its scale, so they may differ from the parameter's
    in the last bits.
    """
    out: list[Obstacle] = []
    for marker in markers:
        if marker.ns != NAMESPACE or marker.action != ADD:
            continue
        x, y = marker.pose.position.x, marker.pose.position.y
        sx, sy = marker.scale.x, marker.scale.y
        if marker.type == CYLINDER:
            out.append(Disc(marker.text, x, y, sx / 2))
        elif marker.type == CUBE:
            out.append(Rect.of(marker.text, x - sx / 2, y - sy / 2, x + sx / 2, y + sy / 2))
        elif marker.type == TRIANGLE_LIST and len(marker.points) >= 3:
            # 3 n - 2 triangles for n vertices; the first n - 2 are the top face's fan.
            n = (len(marker.points) // 3 + 2) // 3
            fan = [(p.x + x, p.y + y) for p in marker.points[:3 * (n - 2)]]
            out.append(Polygon(marker.text, (fan[0], fan[1], *fan[2::3])))
    return tuple(out)


def source_markers(names: Iterable[str], positions: Iterable[Iterable[float]]
                   ) -> tuple[MarkerData, ...]:
    """One sphere per source at ``positions`` ([S, 2] x, y in m, e.g.
    ``CueField.source_positions(t)``), in the order of ``names`` (id = index)."""
    return tuple(MarkerData(k, SPHERE, (float(x), float(y), SOURCE_SIZE / 2),
                            (SOURCE_SIZE, SOURCE_SIZE, SOURCE_SIZE), text=name)
                 for k, (name, (x, y)) in enumerate(zip(names, positions)))


def sources_from_markers(markers: Iterable[object]) -> tuple[tuple[str, float, float], ...]:
    """(name, x, y) of each source that decoded ``/world/sources`` markers show, in order
    (markers of another namespace or action left out)."""
    return tuple((marker.text, marker.pose.position.x, marker.pose.position.y)
                 for marker in markers
                 if marker.ns == SOURCES_NAMESPACE and marker.action == ADD)

"""The simulated arena of a Mona swarm: the world engine both runners step, and its parts.

The modules of this package are the engine (pure: no ROS): ``params`` (the world's
parameters), ``arena`` (walls and obstacles), ``layouts`` (obstacle layouts by name),
``sources`` and ``cue``, ``transport`` and ``field`` (the cue and every change to it),
``physics``, ``placement``, ``world`` (:class:`World`: reset / sense / step;
:class:`WorldBatch`), ``lockstep`` (the rounds with the controllers), ``timing``, ``frames``
and ``reference`` (plain-Python references beside the compiled kernels). Sub-packages,
each with one job:

- ``sensing``: what a simulated Mona senses and how its commands reach its wheels;
- ``messages``: the world's messages without ROS (marker data, cue maps, CDR bytes);
- ``driver``: real Monas, and emulated ones, behind the world's contract;
- ``ros``: the adapters (the world node, the driver node, ``driver_hil``): the only modules
  of the package that import rclpy or a message package (tests/unit/test_layers.py).

Importing the package imports none of them: each name below is imported on first use.
"""

from mona_controller.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('Readings', 'World', 'WorldBatch'), 'world'),
    **dict.fromkeys(('WorldNodeParams', 'WorldParams'), 'params'),
    **dict.fromkeys(('Arena', 'Disc', 'Obstacle', 'Polygon', 'Rect'), 'arena'),
    **dict.fromkeys(('LAYOUTS', 'register_layout'), 'layouts'),
    'Source': 'sources',
    **dict.fromkeys(('CueField', 'initial_cue'), 'field'),
    **dict.fromkeys(('Physics', 'PhysicsBatch'), 'physics'),
    **dict.fromkeys(('PlacementError', 'place_robots', 'placement_rng'), 'placement'),
    **dict.fromkeys(('Answer', 'Lockstep', 'Outcome'), 'lockstep'),
    **dict.fromkeys(('crossed', 'steps_for'), 'timing'),
    **dict.fromkeys(('poses_from_rows', 'yaw_from_quaternion', 'yaw_to_quaternion'), 'frames'),
    **dict.fromkeys(('check_ir', 'check_placement'), 'reference'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

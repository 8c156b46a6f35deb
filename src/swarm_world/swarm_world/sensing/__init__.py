"""What a simulated Mona senses and how its commands reach its wheels (pure: no ROS).

``params`` (:class:`SensingParams`, the ``sensing`` section: the simulator's model of the
sensors and wheels), ``ground`` (the ground sensors: compiled kernels), ``ir`` (the IR ring:
compiled kernels, cell lists) with ``rays`` (a beam against the walls and a shape) and
``headings`` (every heading's cos and sin, which both and the wheels need), ``transfer``
(what a ground sensor reads on a cue value), ``noise`` (counter-based sensor and wheel noise
streams), ``delay`` (the command latency). Importing the package imports none of them.
"""

from mona_controller.exports import lazy_exports

_WHERE = {
    'SensingParams': 'params',
    **dict.fromkeys(('ground_readings', 'sensor_geometry'), 'ground'),
    'heading_trig': 'headings',
    **dict.fromkeys(('proximity', 'proximity_many'), 'ir'),
    **dict.fromkeys(('transfer_table', 'webots_reading'), 'transfer'),
    'NoiseLevels': 'noise',
    'CommandDelay': 'delay',
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

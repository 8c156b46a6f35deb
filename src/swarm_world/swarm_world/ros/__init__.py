"""The world's ROS adapters, the only modules of swarm_world that import rclpy or a message
package: ``world_node`` (the world node: its lockstep and realtime stepping),
``episode_host`` (the episodes' life in a world-side node: announcements, controllers and
recorders joining, start, end, status), ``world_topics`` (the world's own topics),
``robot_link`` (one robot's topics), ``world_messages`` (the world's rclpy messages),
``driver_node`` (real Monas behind the world's topics), ``hil`` and ``hil_tracker``
(``driver_hil``: the driver node against emulated robots). Importing the package imports
none of them (nor rclpy).
"""

from mona_controller.exports import lazy_exports

_WHERE = {'WorldNode': 'world_node', 'DriverNode': 'driver_node'}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

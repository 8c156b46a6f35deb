"""The node system: the supervisor and live nodes, the launcher behind ``mona-swarm launch``
(``scripts/swarm.sh``), node processes and their ROS domains, and replay onto ROS topics.

Only ``supervisor_node``, ``live_node`` and ``replay`` import rclpy; ``launcher`` and
``processes`` start the nodes as executables.
"""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('Supervisor', 'SupervisorError'), 'supervisor_node'),
    **dict.fromkeys(('busy_cores', 'private_domain', 'ros_environment'), 'processes'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

"""The node system: the supervisor and live nodes, the launcher behind ``mona-swarm launch``
(``scripts/swarm.sh``), node processes and their ROS domains, and replay onto ROS topics.

Only the modules of ``ros`` (``supervisor_node``, ``live_node``, ``replay``) import rclpy;
``launcher`` and ``processes`` start the nodes as executables.
"""

from swarm_supervisor.exports import lazy_exports, moved_modules

_WHERE = {
    **dict.fromkeys(('Supervisor', 'SupervisorError'), 'ros.supervisor_node'),
    **dict.fromkeys(('busy_cores', 'private_domain', 'ros_environment'), 'processes'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

# The node modules moved to ros/: their old names forward to the new ones, for one release.
moved_modules(__name__, {name: [f'ros.{name}'] for name in ('live_node', 'replay',
                                                            'supervisor_node')})

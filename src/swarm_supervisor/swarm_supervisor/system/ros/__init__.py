"""The node system's ROS adapters, the only modules of swarm_supervisor that import rclpy or
a message package: ``supervisor_node`` (the supervisor node: announces the episodes, waits
for their ends), ``live_node`` (the live view's node) and ``replay`` (a bag played back onto
its topics). Importing the package imports none of them (nor rclpy).
"""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('Supervisor', 'SupervisorError'), 'supervisor_node'),
    'LiveNode': 'live_node',
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

"""The controller's ROS adapters, the only modules of mona_controller that import rclpy or a
message package: ``controller_node`` (the controller node), ``messages`` (the per-robot
messages and the cores' arrays), ``qos`` (a named QoS per topic), ``ros_params`` (a schema
section declared as ROS parameters) and ``shutdown`` (teardown under a watchdog), which every
node of the four packages uses. Importing the package imports none of them (nor rclpy).
"""

from mona_controller.exports import lazy_exports

_WHERE = {'ControllerNode': 'controller_node'}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

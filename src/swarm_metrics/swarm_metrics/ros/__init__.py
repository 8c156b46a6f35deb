"""The metrics' ROS adapter, the only module of swarm_metrics that imports rclpy:
``metrics_node`` (the metrics node). Importing the package imports none of it (nor rclpy).
"""

from mona_controller.exports import lazy_exports

_WHERE = {'MetricsNode': 'metrics_node'}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

"""The metrics' ROS adapter: the metrics node."""

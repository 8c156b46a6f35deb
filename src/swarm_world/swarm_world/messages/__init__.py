"""The world's messages without ROS: marker data (pure: no ROS)."""

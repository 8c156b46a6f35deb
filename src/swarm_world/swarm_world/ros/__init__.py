"""The world's ROS adapters: the world node, the driver node, the hardware-in-the-loop
harness and the world's rclpy messages."""

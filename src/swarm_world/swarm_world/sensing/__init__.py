"""What a simulated Mona senses and how its commands reach its wheels (pure: no ROS)."""

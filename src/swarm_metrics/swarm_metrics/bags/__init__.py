"""An episode's record (pure: no ROS): writing its bag, reading it, salvaging it, what it
lost, whether it is whole, recording it online, recomputing its metrics."""

"""The real-robot driver: the world node's contract from tracked poses and the link.

Pure cores (no ROS): :mod:`.params` (the driver's options), :mod:`.calibration` (raw IR ADC
to a range and back), :mod:`.wheels` (cmd_vel to the link's wheel commands, PWM back to
speed), :mod:`.tracked` (:class:`~.tracked.TrackedWorld`: the world's cue and sensors at
tracked poses), :mod:`.fleet` (each robot's link: telemetry, commands, faults). The adapter
is :mod:`swarm_world.ros.driver_node`; the hardware-in-the-loop harness is
:mod:`swarm_world.ros.hil`. docs/driver.md.
"""

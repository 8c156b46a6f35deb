"""The link to a real Mona: the binary frame, sequence tracking and transports (ROS-free).

The format is documented in docs/link.md, the one place that defines it for this package and
for the firmware in firmware/mona/.
"""

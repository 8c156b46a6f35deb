"""The real-robot driver: the world node's contract from tracked poses and the link.

Pure cores (no ROS): :mod:`.params` (the driver's options), :mod:`.calibration` (raw IR ADC
to a range and back), :mod:`.wheels` (cmd_vel to the link's wheel commands, PWM back to
speed), :mod:`.tracked` (:class:`~.tracked.TrackedWorld`: the world's cue and sensors at
tracked poses), :mod:`.fleet` (each robot's link: telemetry, commands, faults),
:mod:`.emulation` (emulated robots: their physics, links and tracker) with :mod:`.firmware`
(their firmwares built and run in simavr).
The adapters are :mod:`swarm_world.ros.driver_node` and ``driver_hil``
(:mod:`swarm_world.ros.hil`). docs/driver.md.
"""

from mona_controller.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('DriverParams', 'udp_address'), 'params'),
    **dict.fromkeys(('CalibrationError', 'IrCalibration'), 'calibration'),
    **dict.fromkeys(('pwm_to_permille', 'to_permille', 'twist_to_wheels'), 'wheels'),
    'TrackedWorld': 'tracked',
    'Fleet': 'fleet',
    'EmulatedArena': 'emulation',
    **dict.fromkeys(('Firmware', 'build_images'), 'firmware'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

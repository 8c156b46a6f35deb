"""The world's messages without ROS, for both runners (pure: no ROS).

``markers`` (the robots, obstacles and sources as marker data, and back), ``cue_map`` (the
cue as image and grid data), ``cdr`` (every world message as the CDR bytes rclpy sends: the
embedded runner's bag and live view; a recorded message's stamp read from its bytes). The
rclpy messages the world node publishes are built from the same data in
:mod:`swarm_world.ros.world_messages`. Importing the package imports none of them.
"""

from mona_controller.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('ROBOT_HEIGHT', 'MarkerData', 'obstacle_markers', 'obstacles_from_markers',
                     'source_markers', 'sources_from_markers'), 'markers'),
    **dict.fromkeys(('cue_mono8', 'cue_percent'), 'cue_map'),
    **dict.fromkeys(('TYPESTORE', 'clock_cdr', 'cue_grid_cdr', 'cue_image_cdr', 'float64_cdr',
                     'json_cdr', 'markers_cdr', 'markers_stamp_ns', 'obstacles_cdr',
                     'pose_array_cdr', 'sources_cdr', 'stamp_ns', 'states_cdr',
                     'states_from_cdr', 'string_cdr'), 'cdr'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

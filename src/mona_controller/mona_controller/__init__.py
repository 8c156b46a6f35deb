"""The Mona controller: a pure core (the parameter schema, the Mona, the controller kinds, the
topic contract, the link to a real robot) and its ROS adapters (``ros``: the controller node
and what every node shares)."""

from mona_controller.exports import moved_modules

# Modules that moved: their old names forward to the new ones, for one release.
moved_modules(__name__, {
    'controller': ['controllers.params', 'controllers.beeclust', 'controllers.base'],
    'network': ['controllers.network', 'controllers.network_weights',
                'controllers.network_forward'],
    'reference': ['controllers.reference'],
    **{name: [f'ros.{name}'] for name in ('controller_node', 'messages', 'qos', 'ros_params',
                                          'shutdown')},
})

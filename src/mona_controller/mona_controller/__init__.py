"""The Mona controller: a pure core (schema, mona, controller) and its ROS node."""

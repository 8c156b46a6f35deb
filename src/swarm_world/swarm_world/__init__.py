"""The simulated world: a pure core (cue, physics, sensors, world) and the world node."""

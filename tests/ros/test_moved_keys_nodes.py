"""The nodes read the sensor model's old keys (``mona.<key>``, a parameter file written before
they moved to ``sensing``) for one release: the world node takes each for its new key, the
controller node, which has no use for them, accepts the file; a key given both ways is
refused."""

from __future__ import annotations

import pytest
from rclpy.parameter import Parameter

from mona_controller.mona import MonaParams
from mona_controller.ros.controller_node import ControllerNode
from mona_controller.schema import ParameterError
from swarm_world.ros.world_node import WorldNode

pytestmark = pytest.mark.ros

OLD = [Parameter('mona.ground_noise', value=3.0), Parameter('mona.command_latency', value=2),
       Parameter('mona.ir_range', value=0.02)]


def test_the_world_takes_the_old_keys_and_a_controller_accepts_them(executor):
    world = WorldNode(context=executor.context, parameter_overrides=OLD)
    controller = ControllerNode(0, context=executor.context, parameter_overrides=OLD)
    for node in (world, controller):
        executor.add_node(node)
    assert (world.sensing.ground_noise, world.sensing.command_latency) == (3.0, 2)
    assert world.world.noise.ground == 3.0 and world.world.latency_steps == 2
    assert world.mona == controller.mona == MonaParams(ir_range=0.02)


def test_a_key_given_both_ways_is_refused(executor):
    both = [*OLD, Parameter('sensing.ground_noise', value=3.0)]
    with pytest.raises(ParameterError, match='mona.ground_noise and sensing.ground_noise are '
                                             'both given'):
        WorldNode(context=executor.context, parameter_overrides=both)

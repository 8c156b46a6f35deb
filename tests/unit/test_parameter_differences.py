"""A node compares an announced parameter section as parameters, defaults applied, and names
the keys that differ (a driver's file that leaves keys at their defaults is the same model)."""

from __future__ import annotations

from mona_controller.controllers import ControllerParams
from mona_controller.mappings import differences, flat_fields, to_mapping
from mona_controller.mona import MonaParams


def test_a_section_that_leaves_keys_at_their_defaults_does_not_differ():
    mine = MonaParams()
    shipped_keys_only = {'body_radius': 0.04, 'ir_count': 5}  # ir_range etc. left out
    assert differences(mine, shipped_keys_only, 'mona.') == []
    assert differences(mine, to_mapping(mine), 'mona.') == []
    assert differences(mine, {}, 'mona.') == []


def test_the_differing_keys_are_named_with_both_values():
    mine = MonaParams()
    lines = differences(mine, {'ir_range': 0.05, 'max_wheel_command': 8.0}, 'mona.')
    assert sorted(lines) == ['mona.ir_range: announced 0.05, here 0.03',
                             'mona.max_wheel_command: announced 8.0, here 10.0']


def test_a_kinds_section_is_compared_key_by_key():
    mine = ControllerParams()
    assert differences(mine, {'kind': 'beeclust', 'beeclust': {}}, 'controller.') == []
    assert differences(mine, {'beeclust': {'alpha': 3.0}, 'network': {'hidden': 4}},
                       'controller.') == ['controller.beeclust.alpha: announced 3.0, here 2.0',
                                          'controller.network.hidden: announced 4, here 8']


def test_an_announcement_this_node_cannot_read_says_why():
    lines = differences(ControllerParams(), {'no_such_key': 1}, 'controller.')
    assert len(lines) == 1 and 'unknown parameter controller.no_such_key' in lines[0]
    lines = differences(ControllerParams(), {'mine': {'gain': 1}}, 'controller.')
    assert len(lines) == 1 and 'unknown parameter controller.mine' in lines[0]


def test_flat_fields_still_lists_every_default():
    names = [name for name, _, _ in flat_fields(MonaParams, 'mona.')]
    assert 'mona.ir_span' in names and 'mona.body_radius' in names

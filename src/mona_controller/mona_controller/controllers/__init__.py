"""Controllers: the seam every controller implements, the registry of kinds, and the kinds.

A kind is one class (:class:`Controller`) with its own parameter section and states; the
registry (:data:`CONTROLLERS`) names it for ``controller.kind``. The kinds shipped:
``beeclust`` (:class:`SwarmController`, the paper's), ``network`` (a small neural net),
``solo`` (the solitary rule: stand and clean where the cue is strong) and ``stand_net`` (a
net that decides its stands at the cleaning ticks);
:mod:`.reference` holds BEECLUST's rules in plain Python and :func:`check_controller`.
Importing this package imports none of its modules; each name is imported on first use.
"""

from mona_controller.exports import lazy_exports

__getattr__, __dir__ = lazy_exports(__name__, {
    'CONTROLLERS': 'registry', 'ENTRY_POINTS': 'registry', 'register_controller': 'registry',
    'ControllerParams': 'params',
    'Colour': 'base', 'Command': 'base', 'Controller': 'base', 'State': 'base',
    'controller_class': 'base', 'make_controller': 'base', 'states_for': 'base',
    'states_of': 'base', 'DEFAULT_KIND': 'params',
    'BeeclustParams': 'beeclust', 'SwarmController': 'beeclust',
    'NetworkController': 'network', 'NetworkParams': 'network',
    'SoloController': 'solo', 'SoloParams': 'solo',
    'StandNetController': 'stand_net', 'StandNetParams': 'stand_net',
    'Longhand': 'reference', 'check_controller': 'reference', 'random_readings': 'reference',
})

__all__ = ['BeeclustParams', 'CONTROLLERS', 'Colour', 'Command', 'Controller',
           'ControllerParams', 'DEFAULT_KIND', 'ENTRY_POINTS', 'Longhand',
           'NetworkController', 'NetworkParams', 'SoloController', 'SoloParams',
           'StandNetController', 'StandNetParams', 'State', 'SwarmController',
           'check_controller', 'controller_class', 'make_controller', 'random_readings',
           'register_controller', 'states_for', 'states_of']

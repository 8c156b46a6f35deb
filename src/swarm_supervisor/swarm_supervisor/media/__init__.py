"""Seeing an episode: videos rendered from its bag, and the Foxglove live view."""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    'animate': 'video',
    **dict.fromkeys(('AnimateError', 'Record', 'read_record'), 'recorded'),
    **dict.fromkeys(('LIVE_TOPICS', 'LiveServer', 'LiveView', 'announce'), 'live'),
}
#: The live view's WebSocket port unless told (here, not in ``live``: the CLI's parsers name it
#: without loading the Foxglove SDK).
DEFAULT_PORT = 8765
__all__ = sorted([*_WHERE, 'DEFAULT_PORT'])
__getattr__, __dir__ = lazy_exports(__name__, _WHERE, here=['DEFAULT_PORT'])

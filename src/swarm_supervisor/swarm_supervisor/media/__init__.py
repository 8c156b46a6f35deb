"""Seeing an episode: videos rendered from its bag, and the Foxglove live view."""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    'animate': 'video',
    **dict.fromkeys(('AnimateError', 'Record', 'read_record'), 'recorded'),
    **dict.fromkeys(('DEFAULT_PORT', 'LIVE_TOPICS', 'LiveServer', 'LiveView', 'announce'), 'live'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

"""An episode's record (pure: no ROS): ``writer`` (its rosbag2 + MCAP bag, written crash-safe),
``scan`` (one strict pass over its MCAP file), ``reader`` (the bag read into tables),
``recover`` (a bag whose writer died, salvaged), ``losses`` (what a damaged bag lost),
``completeness`` (the verdict every consumer of a bag uses) with ``checks`` (its checks one
by one), ``recording`` (one bag per episode, metrics online: the metrics node's logic) with
``record`` (what it keeps of an episode), ``analysis`` (the metrics recomputed from a bag).
Importing the package imports none of them.
"""

from mona_controller.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('CHUNK_PERIOD', 'EpisodeBagWriter', 'offered_qos'), 'writer'),
    **dict.fromkeys(('BagError', 'McapScan', 'TruncatedBagError'), 'scan'),
    **dict.fromkeys(('EpisodeBag', 'read_episode_bag'), 'reader'),
    **dict.fromkeys(('recover_bag', 'with_recovery'), 'recover'),
    **dict.fromkeys(('LostChunk', 'lost_chunks'), 'losses'),
    'Finding': 'checks',
    'check_bag': 'completeness',
    'Recorder': 'recording',
    **dict.fromkeys(('Closed', 'EpisodeRecord'), 'record'),
    **dict.fromkeys(('EpisodeSetup', 'MetricsReplica', 'Recomputation', 'recompute'),
                    'analysis'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

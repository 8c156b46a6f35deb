"""An episode's outputs: its folder (metrics.csv, episode.json, snapshots.npz, a PNG), its
embedded bag (the record the metrics node writes) and the pictures of its cue map."""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('EPISODE_FILE', 'FINAL_PNG', 'METRICS_FILE', 'SNAPSHOTS_FILE',
                     'episode_complete', 'episode_record', 'read_metrics_csv',
                     'write_episode', 'write_metrics_csv'), 'episode_folder'),
    **dict.fromkeys(('BagOptions', 'BagRecorder', 'EMBEDDED_MODE', 'RecordError',
                     'TOPICS', 'record_episode', 'status_json'), 'bag'),
    **dict.fromkeys(('draw_cue_map', 'save_cue_map'), 'pictures'),
    **dict.fromkeys(('RECORD_FILES', 'RecordExists', 'check_output', 'check_place',
                     'claim_output', 'empty', 'record_in'), 'guard'),
    **dict.fromkeys(('OutputError', 'check_location'), 'location'),
    **dict.fromkeys(('FolderBusy', 'check_free', 'hold', 'release'), 'lock'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

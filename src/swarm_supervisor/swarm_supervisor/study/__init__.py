"""The study as data: a design of episodes, run in batches on local processes or a Dask
cluster, resumable, tabulated as ``all_metrics.csv``.

``specs`` (the episodes of a design), ``tasks`` (what a worker runs), ``local`` and
``cluster`` (where), ``validate`` and ``folder`` (the refusals before anything runs),
``interrupt`` (stopping without losing an episode), ``run`` (:func:`run_study`), ``table``
(episode folders as one table).
"""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('EpisodeSpec', 'design', 'episode_config', 'factor_cells',
                     'parameter_value', 'quick_study', 'snapshot_times'), 'specs'),
    **dict.fromkeys(('EpisodeFailed', 'StudyError'), 'errors'),
    'check_design': 'validate',
    **dict.fromkeys(('Interrupted', 'StopRequest'), 'interrupt'),
    **dict.fromkeys(('claim_analysis_folder', 'claim_study_folder', 'first_difference',
                     'is_study'), 'folder'),
    **dict.fromkeys(('BAG_DIR', 'EpisodeTask', 'make_batches', 'run_and_write'), 'tasks'),
    **dict.fromkeys(('available_cpus', 'run_local'), 'local'),
    **dict.fromkeys(('ClusterError', 'run_on_cluster'), 'cluster'),
    **dict.fromkeys(('EPISODES_DIR', 'PARAMETERS_FILE', 'TIMING_FILE', 'VIDEOS_DIR',
                     'plan', 'read_invocations', 'render_videos', 'run_study', 'run_tasks'),
                  'run'),
    **dict.fromkeys(('KEYS', 'TABLE_COLUMNS', 'TABLE_FILE', 'added_metrics', 'design_factors',
                     'episode_findings', 'episode_key', 'find_episodes', 'incomplete_episodes',
                     'read_table', 'recorded_findings', 'recorded_plugins', 'tidy_table',
                     'varying_parameters', 'write_table'),
                  'table'),
}
#: Episodes a worker steps together by default (``--batch-size``): on the 2-core development
#: machine the per-episode speed grows up to about 16 (N = 10: 390x alone, 1050x in 16s; N =
#: 50: 240x, 480x) and no further (64: the same or a little slower, caches), and a batch of 16
#: holds about 25 MB of cue maps and snapshots. Here, not in ``tasks``: the CLI's parsers
#: name it without loading the engine.
DEFAULT_BATCH_SIZE = 16
__all__ = sorted([*_WHERE, 'DEFAULT_BATCH_SIZE'])
__getattr__, __dir__ = lazy_exports(__name__, _WHERE, here=['DEFAULT_BATCH_SIZE'])

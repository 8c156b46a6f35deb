"""The metrics of a Mona swarm and the record of its episodes.

``metrics`` (the metric registry: mean cue, ratio near the source, coherency, per source;
:class:`MetricsParams`) is the core; sub-packages, each with one job:

- ``bags``: an episode's record (pure: no ROS): writing its bag, reading it, salvaging it,
  what it lost, whether it is whole, recording it online, recomputing its metrics;
- ``ros``: the adapter (the metrics node): the only module of the package that imports
  rclpy (tests/unit/test_layers.py).

Importing the package imports none of them: each name below is imported on first use.
"""

from mona_controller.exports import lazy_exports

_WHERE = dict.fromkeys(('METRICS', 'Metric', 'MetricsParams', 'Sample', 'metric_names',
                        'register', 'sample_field', 'unregister'), 'metrics')
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

"""Calibrating the model against the paper: a search over declared ranges of any parameters,
scored by the paper's claims and its table 2 (``mona-swarm calibrate``)."""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('CalibrationDesign', 'CalibrationError', 'Objective', 'PAPER_RATIO',
                     'PURPOSES', 'Range', 'load_design'), 'design'),
    **dict.fromkeys(('Score', 'score', 'speed_population_ratio'), 'objective'),
    **dict.fromkeys(('TrialResult', 'load_results', 'run_search'), 'search'),
    **dict.fromkeys(('best_file', 'candidates', 'confirm', 'write_report'), 'report'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

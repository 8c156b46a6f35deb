"""From episodes to results: figures 3-6, the ANOVA of tables 2 and 3, the paper's claims
checked on our data, their sensitivity to a sweep's factors, and report.md."""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    'analyse': 'report', 'REPORT_FILE': 'report',
    **dict.fromkeys(('compare_variants', 'write_anova'), 'anova'),
    **dict.fromkeys(('Claim', 'ClaimError', 'ClaimResult', 'all_claims', 'load_claims',
                     'paper_claims'), 'claims'),
    **dict.fromkeys(('evaluate', 'evaluate_levels'), 'checks'),
    **dict.fromkeys(('claim_matrix', 'write_sensitivity'), 'sensitivity'),
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)

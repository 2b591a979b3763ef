"""ObservabilityAnalysis speaks the result protocol (issue 13)."""

import json

from canonical import slab_pwa

from hybobs_opt import SolveResult, Status, analyse_observability


def test_analysis_is_a_solve_result_with_its_summary():
    analysis = analyse_observability(slab_pwa(3, 2, 2), 2)
    assert isinstance(analysis, SolveResult)
    assert analysis.status is Status.OPTIMAL and analysis.residuals == {}
    rec = json.loads(json.dumps(analysis.to_dict()))
    assert rec["status"] == "optimal"
    assert {k: v for k, v in rec.items() if k != "status"} == json.loads(json.dumps(analysis.summary()))
    assert analysis.total_seconds == rec["seconds"]

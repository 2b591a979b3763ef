"""Paper 000: the driveline run of Fig. 6 (location observer and switched continuous observer).

The location changes of the figure and their detection within the designed delay, on the run of
:func:`hybobs_opt.studies.paper000_driveline.scenario.run_driveline`.  The guarantees of the
designs (Propositions 3.1.1, 3.1.3, 3.3.1) are unit tests in
``tests/unit/observers/test_location_observer.py``; the driveline's physics in
``tests/studies/test_automaton_examples.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from observer_checks import delays_from_events

from hybobs_opt.observers.location_logic import AMBIGUOUS
from hybobs_opt.studies.paper000_driveline.scenario import run_driveline


# ---------------------------------------------------------------------------- the driveline (Fig. 6)
@pytest.fixture(scope="module")
def fig6():
    return run_driveline()


def test_driveline_has_the_fig6_location_changes(fig6):
    aut, tr = fig6.automaton, fig6.trace
    names = aut.location_names
    # q3 -> q2 when the torsion deviation falls through -theta_e0 + theta_1 = -0.01 rad, and back
    assert [(names[e["from"]], names[e["to"]]) for e in tr.events] == [("q3", "q2"), ("q2", "q3")]
    for e in tr.events:
        assert e["x"][0] == pytest.approx(-0.025 + 0.015, abs=1e-9)
    assert tr.events[1]["t"] - tr.events[0]["t"] >= fig6.bound.dwell_time


def test_driveline_detection_delay_within_designed_delta(fig6):
    tr, run, delta = fig6.trace, fig6.run, fig6.bank.delta
    delays = delays_from_events(tr.t, tr.events, run.location)
    assert len(delays) == 2
    assert all(0.0 <= d <= delta for d in delays), delays
    assert fig6.summary["detection_delays"] == pytest.approx(delays)
    # never a wrong location: between changes the estimate is the truth or an ambiguity report
    assert np.all((run.location == tr.q) | (run.location == -1))
    assert fig6.summary["ambiguous_steps"] == int(np.count_nonzero(run.status == AMBIGUOUS))

"""Issue 16: the observability analysis does not depend on the units of the states.

``x' = S x`` (``S`` diagonal) turns the powertrain of model (16) into an equivalent system
(``S A S^-1``, ``S B``, ``S a``, ``C S^-1``, guards and state box mapped by ``S^-1``); every state's
label must then be the same at ``S x`` as at ``x``.  Before the LP layer equilibrated its LPs,
scalings by 1e-6 changed labels (HiGHS's absolute tolerances and 1e-9 small-value threshold saw a
different problem) and 1e6 raised a SolverError in the bounding boxes of the regions.
"""

import functools

import numpy as np
import pytest

from hybobs_opt.regions import analyse_observability
from hybobs_opt.studies import get_example
from hybobs_opt.systems import Polytope, PWAMode, PWASystem

T = 3
N_POINTS = 46


def rescaled(system: PWASystem, s) -> tuple[PWASystem, np.ndarray]:
    """The system in states ``x' = S x``, and ``S``."""
    n, m = system.n, system.m
    S = np.diag(np.broadcast_to(np.asarray(s, dtype=float), (n,)))
    Si = np.diag(1.0 / np.diag(S))
    Txu = np.eye(n + m)
    Txu[:n, :n] = Si
    modes = [PWAMode(S @ md.A @ Si, S @ md.B, S @ md.a, md.C @ Si, Polytope(md.guard.A @ Txu, md.guard.b, md.guard.names),
                     md.D, md.c, md.name) for md in system.modes]
    X = system.state_bounds
    return PWASystem(modes, Polytope(X.A @ Si, X.b, X.names), system.input_bounds, system.state_names, system.input_names,
                     system.output_names, system.Ts, system.name, system.partition), S


@functools.cache
def reference():
    system = get_example("powertrain3").build()
    analysis = analyse_observability(system, T)
    half, centre = system.scales()
    n = system.n
    rng = np.random.default_rng(0)
    X = centre[:n] + half[:n] * rng.uniform(-1, 1, (N_POINTS, n))
    return system, analysis, X, [analysis.classify(x) for x in X]


def test_reference_labels_exercise_every_answer():
    _, _, _, labels = reference()
    assert {"observable", "unobservable", "infeasible"} <= set(labels)


@pytest.mark.parametrize("s", [1e-6, 1e-3, 1e3, 1e6, (1e6, 1.0, 1.0), (1.0, 1e6, 1e-6), (1e-6, 1e6, 1.0)], ids=str)
def test_rescaled_powertrain_gives_the_same_labels(s):
    system, analysis, X, labels = reference()
    scaled, S = rescaled(system, s)
    an = analyse_observability(scaled, T)
    got = [an.classify(S @ x) for x in X]
    wrong = [(x.tolist(), a, b) for x, a, b in zip(X, labels, got) if a != b]
    assert not wrong, f"{len(wrong)} of {N_POINTS} labels change at scale {s}: {wrong[:5]}"
    ref, new = analysis.summary(), an.summary()
    for key in ("n_regions", "n_full_rank", "n_unobservable_pieces", "n_pairs_dropped_thin", "n_pairs_dropped_same_state"):
        assert new[key] == ref[key], (key, new[key], ref[key])

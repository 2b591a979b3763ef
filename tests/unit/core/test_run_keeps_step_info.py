"""``Observer.run`` keeps every step's ``Estimate.info`` (issue 14: ``MHEObserver.run`` dropped it)."""

import numpy as np

from hybobs_opt import MHEObserver, PWAMode, PWASystem, Polytope
from hybobs_opt.observers.comparison import timed_steps


def scalar_system():
    """x+ = 0.5 x + u on [-1, 1] (two modes split at 0 with the same dynamics), y = x."""
    modes = tuple(PWAMode(np.array([[0.5]]), np.array([[1.0]]), np.zeros(1), np.array([[1.0]]),
                          Polytope(np.array([[s, 0.0]]), np.zeros(1)), name=nm) for s, nm in ((-1.0, "pos"), (1.0, "neg")))
    return PWASystem(modes, Polytope.from_box([-1.0], [1.0]), Polytope.from_box([-0.2], [0.2]), ("x",), ("u",), ("y",))


def test_mhe_run_keeps_per_step_info_and_it_matches_step():
    system = scalar_system()
    U = np.array([[0.1], [-0.1], [0.05], [0.0], [0.1]])
    x, Y = 0.4, []
    for u in U[:, 0]:
        Y.append([x])
        x = 0.5 * x + u
    obs = MHEObserver(system, 2)
    obs.reset()
    trace = obs.run(U, np.array(Y))
    assert len(trace.info) == trace.n_steps == 5
    # the steps after warm-up were solved: the info says by which solver and with which status
    assert all("status" in trace.info[k] and "solver" in trace.info[k] for k in range(1, 5))
    obs.reset()
    stepped = [obs.step(U[k], Y[k]).info.get("status") for k in range(5)]
    assert [i.get("status") for i in trace.info] == stepped
    chunked = timed_steps(obs, U, np.array(Y), progress=lambda done, total: None, chunk=2)
    assert [i.get("status") for i in chunked.info] == stepped

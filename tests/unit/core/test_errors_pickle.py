"""Errors cross process boundaries intact (issue 16: a SolverError raised in a worker of the
process executor broke the pool with a TypeError while unpickling, losing the message)."""

import pickle
from concurrent.futures import ProcessPoolExecutor

import pytest

from hybobs_opt.errors import BuildError, InfeasibleError, ModelError, SolverError

ERRORS = [
    ModelError("modes[2].A", "a (3, 3) matrix", "shape (2, 2)"),
    ModelError("x0", "a finite state"),
    SolverError("pair test (3, 7)", "HiGHS", "optimal point violates A x <= b", "rescale the model"),
    InfeasibleError("LMI (8)", None, "no common P"),
    BuildError("the exported C in 'out'", "compile", "x.c:1: error: expected ';'"),
]


@pytest.mark.parametrize("err", ERRORS, ids=lambda e: type(e).__name__)
def test_an_error_survives_pickling_with_its_fields(err):
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is type(err) and str(back) == str(err) and vars(back) == vars(err)


def _raise(err):
    raise err


def test_an_error_raised_in_a_worker_reaches_the_caller():
    err = SolverError("pair test (3, 7)", "HiGHS", "time limit", "a longer limit")
    with ProcessPoolExecutor(max_workers=1) as pool:
        with pytest.raises(SolverError, match="pair test") as got:
            pool.submit(_raise, err).result()
    assert got.value.solver == "HiGHS" and got.value.hint == "a longer limit"

"""Fuzz family 2: observer sample sequences with faults (issue 16).

For every observer kind on its example's scenario (:mod:`.scenarios`), hypothesis draws one to
three faults at drawn steps of the scenario's fault window: NaN, +-inf, +-1e300, +-1e12, ten times
the largest output, wrong-length, string, ``None``, complex and nested samples, the same faults on
the inputs, time-stamp faults (1e300, -1e9, NaN, inf, 1e12, a stamp going back) for the
event-driven drift and periodic observers and non-integer or impossible outputs for their
integer-valued output.  Each faulted run is classified:

* ``other-exception:<type>`` if a step raised (runtime observers never raise on a bad sample);
* ``wrong-flagged-good`` if a step flagged ``observable`` has an error above the tolerance the
  observer states (Luenberger-type observers: their ``info['error_bound']`` plus
  :data:`~.scenarios.BOUND_FLOOR_FRACTION` of the box for the integration error; the others: 10 x
  the clean run's largest error on its observable steps plus 1 % of the box);
* ``not-recovered`` if the last steps' flags differ from the clean run's or their estimates are
  further from the truth than the clean run's tolerance;
* ``observer-ok`` otherwise.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.contract import OBSERVABLE

from . import strategies as S
from .common import (
    NOT_RECOVERED,
    OBSERVER_OK,
    WRONG_FLAGGED_GOOD,
    Family,
    Target,
    assert_no_bugs,
    other,
    run_target,
    strict_warnings,
)
from .scenarios import BOX_FLOOR_FRACTION, CLEAN_ERROR_FACTOR, scenario

CHANNELS = {"y": S.Y_FAULTS, "u": S.U_FAULTS, "t": S.T_FAULTS, "int-y": S.INT_Y_FAULTS}


def faulted_samples(sc, faults) -> tuple[list, list[tuple[int, str]]]:
    """The clean samples of ``sc`` with ``faults`` = [(where, kind, j)] applied; and the faulted steps."""
    channel_of = {}
    samples = sc.clean_samples()
    lo, hi = sc.window
    ymax = np.max(np.abs(sc.Y), axis=0)
    umax = np.max(np.abs(sc.U), axis=0) if sc.m else np.zeros(0)
    done = []
    for where, (channel, kind), j in faults:
        k = lo + int(where * (hi - lo))
        u, y = samples[k]
        if channel == "t":
            t = np.asarray(u, dtype=float).copy()
            if kind == "back":
                t[0] = float(sc.U[max(k - 2, 0), 0]) - 1e-9 * (1.0 + abs(float(sc.U[max(k - 2, 0), 0])))
            else:
                t[0] = {"+1e300": 1e300, "-1e9": -1e9, "nan": np.nan, "+inf": np.inf, "+1e12": 1e12}[kind]
            u = t
        elif channel == "u":
            u = S.bad_vector(kind, u, umax, j)
        else:
            y = S.bad_vector(kind, y, ymax, j)
        samples[k] = (u, y)
        channel_of[k] = channel
        done.append((k, f"{channel}:{kind}"))
    return samples, done


def classify_run(sc, faults) -> tuple[str, str]:
    samples, done = faulted_samples(sc, faults)
    clean = sc.clean()
    try:
        with strict_warnings():
            run = sc.run(samples)
    except Exception as exc:
        return other(exc), f"{sc.name} faults {done}: {type(exc).__name__}: {exc}"
    tol = sc.tolerance(run)
    observable = run["flags"] == OBSERVABLE
    wrong = np.nonzero(observable & (run["err"] > tol).any(axis=1))[0]
    if wrong.size:
        k = int(wrong[0])
        return WRONG_FLAGGED_GOOD, (f"{sc.name} faults {done}: {wrong.size} steps flagged observable with an error above "
                                    f"the tolerance, first k={k}: error {run['err'][k].tolist()} > tol {tol[k].tolist()}")
    w = sc.recovery_window()
    flags_f, flags_c = run["flags"][w], clean["flags"][w]
    rec_tol = CLEAN_ERROR_FACTOR * clean["err"][w].max(axis=0) + BOX_FLOOR_FRACTION * sc.width
    if not np.array_equal(flags_f, flags_c) or np.any(run["err"][w] > rec_tol):
        diff = int(np.count_nonzero(flags_f != flags_c))
        return NOT_RECOVERED, (f"{sc.name} faults {done}: last {flags_f.size} steps: {diff} flags differ from the clean run "
                               f"(faulted {dict(zip(*np.unique(flags_f.astype(str), return_counts=True)))}), final error "
                               f"{run['err'][-1].tolist()} (clean {clean['err'][-1].tolist()})")
    return OBSERVER_OK, f"{sc.name} faults {done}"


def _faults(kinds, most: int):
    return S.st.lists(S.st.tuples(S.st.floats(0.0, 1.0, exclude_max=True, allow_nan=False), S.st.sampled_from(kinds),
                                  S.st.integers(0, 7)), min_size=1, max_size=most)


def _target(name: str, channels: tuple[str, ...], examples: int, most: int = 3, explicit: tuple = ()) -> Target:
    """Faults of ``channels`` on scenario ``name``; channel ``"outlier"`` is ten times the largest
    output (and input) of the run, inside the model's range, which the other channels leave out."""
    if channels == ("outlier",):
        sc_m = name.startswith(("driveline", "powertrain", "magnetic", "vehicle"))
        kinds = (("y", "10x"),) + ((("u", "10x"),) if sc_m else ())
    else:
        kinds = tuple((c, k) for c in channels for k in CHANNELS[c] if k not in ("complex", "10x"))
    label = f"{name} [{'+'.join(channels)}{'' if most == 3 else f', at most {most} fault'}]"
    return Target(label, _faults(kinds, most), lambda v, n=name: classify_run(scenario(n), v), examples, explicit)


def _complex_target(examples: int) -> Target:
    """Complex samples (output, or input where there is one) on every observer: a drawn scenario."""
    names = sorted({n for n, *_ in PLAN})

    def try_one(v):
        name, fl = v
        sc = scenario(name)
        channel = "u" if (sc.m and not sc.time_input and fl[0][2] % 2) else "y"
        return classify_run(sc, [(w, (channel, "complex"), j) for w, _, j in fl])

    return Target("every observer [complex samples]", S.st.tuples(S.st.sampled_from(names), _faults(("complex",), 1)),
                  try_one, examples)


#: (scenario, fault channels, pytest examples[, most faults per run[, explicit inputs]]): the
#: observers with inputs get input faults, the event-driven ones time-stamp and integer-output
#: faults.  The explicit inputs are the faults of the probe behind issue 16 (one sample of
#: u = -1e12 in the middle of the run).
PLAN = [
    ("driveline-hybrid", ("y",), 2), ("driveline-hybrid", ("u",), 2), ("driveline-hybrid", ("outlier",), 1),
    ("driveline-location", ("y",), 3), ("driveline-location", ("u",), 2), ("driveline-location", ("outlier",), 1),
    ("driveline-continuous", ("y",), 3), ("driveline-continuous", ("u",), 2), ("driveline-continuous", ("outlier",), 1),
    ("powertrain3-lookup", ("y",), 10), ("powertrain3-lookup", ("u",), 8), ("powertrain3-lookup", ("outlier",), 5),
    ("powertrain3-miqp", ("y",), 6), ("powertrain3-miqp", ("u",), 5), ("powertrain3-miqp", ("outlier",), 3),
    ("sliding-double_scroll", ("y",), 4), ("sliding-double_scroll", ("outlier",), 2),
    ("sliding-triangular", ("y",), 2), ("sliding-triangular", ("outlier",), 1),
    ("magnetic_piston", ("y",), 2), ("magnetic_piston", ("u",), 1, 3, ([(0.5, ("u", "-1e12"), 0)],)),
    ("magnetic_piston", ("outlier",), 1),
    ("vehicle_tracking", ("y",), 1), ("vehicle_tracking", ("u",), 1), ("vehicle_tracking", ("outlier",), 1),
    ("drift-traffic_junction", ("t", "y", "int-y"), 12),
    ("drift-switching_server", ("t", "y", "int-y"), 12),
    ("periodic-switching_server", ("t", "y", "int-y"), 12, 1),
    ("periodic-switching_server", ("t", "y", "int-y"), 12),
]

FAMILY = Family(
    "observer samples",
    "no exception, no step flagged observable off the truth by more than the stated tolerance, recovery to the clean run",
    [_target(*row) for row in PLAN] + [_complex_target(12)],
)

_OUTLIER = ("an output or input ten times the run's largest, inside the model's range, is used as a good sample: "
            "{what}")

#: Targets where the fuzz finds a defect today (strict: fixing the defect turns them into failures to remove).
KNOWN_DEFECTS: dict[str, str] = {
}


def _param(t: Target):
    reason = KNOWN_DEFECTS.get(t.name)
    marks = [pytest.mark.xfail(strict=True, reason=reason)] if reason else []
    return pytest.param(t, id=t.name, marks=marks)


@pytest.mark.parametrize("target", [_param(t) for t in FAMILY.targets])
def test_bad_samples(target):
    assert_no_bugs(run_target(target))


@pytest.mark.parametrize("name", sorted({row[0] for row in PLAN}))
def test_clean_run_meets_its_own_tolerance(name):
    """The oracle is sound: the clean run has no step flagged observable off by more than the tolerance."""
    sc = scenario(name)
    c = sc.clean()
    observable = c["flags"] == OBSERVABLE
    assert not np.any(observable & (c["err"] > sc.tolerance(c)).any(axis=1))


# ---------------------------------------------------------------------------------- the defects, one run each

#: ``(id, scenario, faults)``: ``faults`` as the strategies draw them, ``(where in the window, (channel, kind), j)``.
DEFECTS = [
    ("complex-output-sample", "powertrain3-lookup", [(0.5, ("y", "complex"), 0)]),
    ("piston-input-minus-1e12", "magnetic_piston", [(0.5, ("u", "-1e12"), 0)]),
    ("continuous-output-outlier", "driveline-continuous", [(0.7, ("y", "10x"), 0)]),
    ("location-input-outlier", "driveline-location", [(0.0, ("u", "10x"), 0)]),
    ("mhe-output-outlier", "powertrain3-miqp", [(0.5, ("y", "10x"), 0)]),
    ("periodic-two-refused-events", "periodic-switching_server", [(0.6, ("t", "+1e300"), 0), (0.65, ("y", "+inf"), 0)]),
]


#: Defects of :data:`DEFECTS` that are fixed: their runs are ordinary regression tests now.
FIXED = {"complex-output-sample", "piston-input-minus-1e12", "periodic-two-refused-events",
         "continuous-output-outlier", "location-input-outlier",
         "mhe-output-outlier"}


@pytest.mark.parametrize("name, faults", [
    pytest.param(n, f, id=i, marks=[] if i in FIXED else pytest.mark.xfail(strict=True, reason="defect found by the fuzz"))
    for i, n, f in DEFECTS])
def test_defect(name, faults):
    outcome, detail = classify_run(scenario(name), faults)
    assert outcome == OBSERVER_OK, detail

"""The partition check of PWA guards (check_partition, PWASystem(partition=...)), tested from outside.

Hand-made cases (a gap, an overlap, shared boundaries) check the verdict and the point the message
reports (parsed back from the message).  An oracle compares the verdict on random 2-D partitions
with a brute-force test: every guard is a union of cells of a fixed line arrangement (the lines
x = k/4, y = k/4, x + y = k/4, x - y = k/4 cut [-1, 1]^2 into 256 triangles), so testing the
centroid of each triangle decides exactly whether some open triangle lies in no guard (a gap)
or in two guards (an overlap); each triangle has an inscribed radius of about 0.037, far above
the tolerance of the check.
"""

import re

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.systems import Polytope, PWAMode, PWASystem, check_partition

BOX = Polytope.from_box([-1.0, -1.0], [1.0, 1.0])


def system(guards, partition="check", inputs=None):
    """A 2-state PWA system (identity dynamics) whose mode ``i`` has the guard ``guards[i] = (A, b)``."""
    m = 0 if inputs is None else inputs.dim
    modes = tuple(PWAMode(np.eye(2) * (i + 1), np.zeros((2, m)), np.zeros(2), np.array([[1.0, 0.0]]),
                          Polytope(np.atleast_2d(np.asarray(A, float)), np.atleast_1d(np.asarray(b, float))), name=f"g{i}")
                  for i, (A, b) in enumerate(guards))
    return PWASystem(modes, BOX, inputs, ("x1", "x2"), ("u",) if m else (), ("y",), partition=partition)


def reported_point(message: str, names=("x1", "x2")) -> np.ndarray:
    values = []
    for name in names:
        found = re.search(rf"\b{name}=([-+0-9.eEinfa]+)", message)
        assert found, (name, message)
        values.append(float(found.group(1)))
    return np.array(values)


# ---------------------------------------------------------------------------------- hand cases

GAP = [([[1, 0]], [-0.1]), ([[-1, 0]], [-0.1])]          # x1 <= -0.1, x1 >= 0.1
OVERLAP = [([[1, 0]], [0.2]), ([[-1, 0]], [0.2])]        # x1 <= 0.2, x1 >= -0.2


@pytest.mark.parametrize("partition", ["check", "ordered"])
def test_a_gap_is_refused_with_a_point_inside_it(partition):
    with pytest.raises(ModelError) as info:
        system(GAP, partition)
    message = str(info.value)
    assert info.value.field == "modes[*].guard" and "gap" in message
    x1, x2 = reported_point(message)
    assert -0.1 < x1 < 0.1
    assert -1.0 <= x2 <= 1.0


def test_an_overlap_is_refused_with_a_point_inside_it():
    with pytest.raises(ModelError) as info:
        system(OVERLAP)
    message = str(info.value)
    assert message.startswith("modes[0].guard and modes[1].guard (g0, g1)")
    x1, x2 = reported_point(message)
    assert -0.2 < x1 < 0.2
    assert -1.0 <= x2 <= 1.0


def test_an_overlap_is_named_by_the_pair_that_overlaps():
    # x1 <= -0.5 | -0.5 <= x1 <= 0.5 | x1 >= 0.25: only modes 1 and 2 overlap, on 0.25 < x1 < 0.5
    guards = [([[1, 0]], [-0.5]), ([[-1, 0], [1, 0]], [0.5, 0.5]), ([[-1, 0]], [-0.25])]
    with pytest.raises(ModelError) as info:
        system(guards)
    assert str(info.value).startswith("modes[1].guard and modes[2].guard (g1, g2)")
    x1, _ = reported_point(str(info.value))
    assert 0.25 < x1 < 0.5


@pytest.mark.parametrize("guards", [
    [([[1, 0]], [0.0]), ([[-1, 0]], [0.0])],                                       # x1 = 0
    [([[1, 1]], [0.3]), ([[-1, -1]], [-0.3])],                                     # x1 + x2 = 0.3
    [([[1, 0]], [0.0]), ([[-1, 0], [0, 1]], [0.0, 0.0]), ([[-1, 0], [0, -1]], [0.0, 0.0])],  # three meet at 0
    [([[1, 0]], [1.0])],                                                           # one guard, the whole box
], ids=["vertical", "diagonal", "three", "single"])
def test_shared_boundaries_are_not_overlaps(guards):
    s = system(guards)
    assert s.partition == "check"
    check_partition(s)  # also callable on its own


@pytest.mark.parametrize("partition", ["check", "ordered", "none"])
def test_a_guard_that_meets_the_box_on_an_edge_only_is_refused(partition):
    # x1 >= 1 is a segment of the box: not full-dimensional (refused before the partition is looked at)
    with pytest.raises(ModelError) as info:
        system([([[1, 0]], [5.0]), ([[-1, 0]], [-1.0])], partition)
    assert info.value.field == "modes[1].guard" and "full-dimensional" in str(info.value)


def test_ordered_accepts_an_overlap_and_resolves_it_by_mode_order():
    s = system(OVERLAP, "ordered")
    assert s.mode_of([0.0, 0.5]) == 0           # in both guards: the first wins
    assert s.mode_of([0.5, 0.5]) == 1
    np.testing.assert_array_equal(s.step([0.0, 0.5]), [0.0, 0.5])
    np.testing.assert_array_equal(s.step([0.5, 0.5]), [1.0, 1.0])


def test_none_accepts_a_gap_and_an_overlap():
    s = system(GAP, "none")
    with pytest.raises(ModelError):
        s.mode_of([0.0, 0.0])                     # in the gap
    assert s.mode_of([-0.5, 0.0]) == 0 and s.mode_of([0.5, 0.0]) == 1
    s = system(OVERLAP, "none")
    assert s.mode_of([0.1, 0.0]) == 0
    # check_partition called directly still finds what construction skipped
    with pytest.raises(ModelError):
        check_partition(s)
    check_partition(s, overlaps=False)
    with pytest.raises(ModelError) as info:
        check_partition(system(GAP, "none"), overlaps=False)
    assert -0.1 < reported_point(str(info.value))[0] < 0.1


@pytest.mark.parametrize("value", ["Check", "", "strict", None, 1, "none "])
def test_an_invalid_partition_value_is_refused(value):
    with pytest.raises(ModelError) as info:
        system([([[1, 0]], [1.0])], value)
    assert info.value.field == "partition"


def test_a_gap_across_an_input_is_reported_by_the_input_name():
    U = Polytope.from_box([-1.0], [1.0])
    guards = [([[0, 0, 1]], [-0.5]), ([[0, 0, -1]], [-0.5])]  # u <= -0.5, u >= 0.5
    with pytest.raises(ModelError) as info:
        system(guards, inputs=U)
    x1, x2, u = reported_point(str(info.value), ("x1", "x2", "u"))
    assert -0.5 < u < 0.5 and -1 <= x1 <= 1 and -1 <= x2 <= 1


def test_thin_slivers_below_the_tolerance_are_ignored_and_thin_gaps_above_it_are_not():
    system([([[1, 0]], [0.0]), ([[-1, 0]], [-1e-10])])   # a gap 1e-10 wide: ignored
    system([([[1, 0]], [1e-10]), ([[-1, 0]], [0.0])])    # an overlap 1e-10 wide: ignored
    with pytest.raises(ModelError) as info:
        system([([[1, 0]], [0.0]), ([[-1, 0]], [-1e-3])])
    assert 0.0 < reported_point(str(info.value))[0] < 1e-3
    with pytest.raises(ModelError) as info:
        system([([[1, 0]], [1e-3]), ([[-1, 0]], [0.0])])
    assert 0.0 < reported_point(str(info.value))[0] < 1e-3


# ---------------------------------------------------------------------------------- oracle

H = 0.25
NORMALS = np.array([[1, 0], [0, 1], [1, 1], [1, -1]], dtype=float)
_sq = np.arange(-1.0, 1.0, H)
_CX, _CY = np.meshgrid(_sq, _sq, indexing="ij")
_OFFSETS = np.array([[0.5, 1 / 6], [0.5, 5 / 6], [1 / 6, 0.5], [5 / 6, 0.5]]) * H
#: The centroids of the 256 triangles of the arrangement.
CENTROIDS = (np.stack([_CX.ravel(), _CY.ravel()], axis=1)[:, None, :] + _OFFSETS[None]).reshape(-1, 2)


def inside(guard, points):
    A, b = guard
    return np.all(points @ np.asarray(A).T <= np.asarray(b) + 1e-12, axis=1)


def random_partition(rng):
    """Guards on the arrangement: a random recursive split of the box, then perhaps one defect."""
    cells = [([], [])]
    for _ in range(rng.integers(1, 5)):
        order = rng.permutation(len(cells))
        for ci in order:
            rows, rhs = cells[ci]
            pts = CENTROIDS[inside((np.array(rows).reshape(-1, 2), np.array(rhs)), CENTROIDS)] if rows else CENTROIDS
            for _ in range(20):
                a = NORMALS[rng.integers(4)]
                k = rng.integers(-7, 8)
                side = pts @ a <= k * H
                if side.any() and (~side).any():
                    cells[ci:ci + 1] = [(rows + [a], rhs + [k * H]), (rows + [-a], rhs + [-k * H])]
                    break
            else:
                continue
            break
    guards = [(np.array(r).reshape(-1, 2), np.array(b, dtype=float)) for r, b in cells]
    def move(i, sign):
        A, b = guards[i]
        if len(b):
            b = b.copy()
            b[rng.integers(len(b))] += sign * H * rng.integers(1, 3)
            guards[i] = (A, b)

    defect = rng.integers(5)
    i = rng.integers(len(guards))
    if defect == 1:                 # move one side of one guard outwards: an overlap, or nothing
        move(i, +1)
    elif defect == 2:               # ... inwards: a gap (or an empty guard, redrawn)
        move(i, -1)
    elif defect == 3 and len(guards) > 1:  # drop a guard: a gap
        guards.pop(i)
    elif defect == 4:               # one side out, another in: both, perhaps
        move(i, +1)
        move(rng.integers(len(guards)), -1)
    if len(guards) > 1 and rng.uniform() < 0.15:  # a guard given twice: an overlap
        guards.append(guards[0])
    if len(guards[0][1]) == 0:
        guards[0] = (np.array([[1.0, 0.0]]), np.array([1.0]))  # the whole box, written as one row
    return guards


def brute_force(guards):
    counts = sum(inside(g, CENTROIDS).astype(int) for g in guards)
    return bool(np.any(counts == 0)), bool(np.any(counts >= 2))


def _instances():
    out, rng = [], np.random.default_rng(7)
    while len(out) < 30:
        guards = random_partition(rng)
        if all(inside(g, CENTROIDS).any() for g in guards):  # every guard full-dimensional in the box
            out.append(guards)
    return out


INSTANCES = _instances()


def test_the_oracle_instances_cover_every_verdict():
    verdicts = [brute_force(g) for g in INSTANCES]
    assert (False, False) in verdicts and any(gap and not ov for gap, ov in verdicts)
    assert any(ov and not gap for gap, ov in verdicts) and (True, True) in verdicts


@pytest.mark.parametrize("index", range(len(INSTANCES)))
def test_verdict_agrees_with_the_brute_force_grid(index):
    guards = INSTANCES[index]
    gap, overlap = brute_force(guards)
    # partition="check": refused exactly when there is a gap or an overlap
    if not (gap or overlap):
        system(guards, "check")
    else:
        with pytest.raises(ModelError) as info:
            system(guards, "check")
        message = str(info.value)
        point = reported_point(message)
        assert np.all(np.abs(point) <= 1 + 1e-9)
        found = re.match(r"modes\[(\d+)\]\.guard and modes\[(\d+)\]\.guard", message)
        if overlap:  # overlaps are looked for first
            assert found, message
            i, j = int(found.group(1)), int(found.group(2))
            p = point[None, :]
            strictly = [np.all(p @ guards[k][0].T < guards[k][1] - 1e-6) for k in (i, j)]
            assert all(strictly), (message, guards[i], guards[j])
        else:
            assert not found and "gap" in message
            p = point[None, :]
            assert not any(np.all(p @ g[0].T <= g[1] + 1e-6) for g in guards), message
    # partition="ordered": refused exactly when there is a gap
    if gap:
        with pytest.raises(ModelError) as info:
            system(guards, "ordered")
        assert "gap" in str(info.value)
    else:
        s = system(guards, "ordered")
        # every centroid has a mode, and it is the first guard that holds it
        first = np.argmax(np.stack([inside(g, CENTROIDS) for g in guards], axis=1), axis=1)
        np.testing.assert_array_equal(s.modes_of(CENTROIDS), first)
    system(guards, "none")


def test_a_repeated_check_gives_the_first_verdict_and_a_changed_guard_is_checked_again(monkeypatch):
    """The verdicts are remembered by a digest of the guards, the domain and the names: the same
    system again gives the same error (same field and text) without re-solving; one guard moved
    by one ulp is a new system and is checked from scratch; the memory is bounded."""
    import hybobs_opt.systems.pwa as pwa

    monkeypatch.setattr(pwa, "_PARTITION_OUTCOMES", type(pwa._PARTITION_OUTCOMES)())
    calls = []
    real = pwa._check_partition
    monkeypatch.setattr(pwa, "_check_partition", lambda s, o: (calls.append(s.name), real(s, o))[1])
    messages = []
    for _ in range(2):
        with pytest.raises(ModelError) as info:
            system(GAP)
        messages.append((info.value.field, str(info.value)))
    assert messages[0] == messages[1] and len(calls) == 1
    good = [([[1, 0]], [0.0]), ([[-1, 0]], [0.0])]
    system(good)
    system(good)
    assert len(calls) == 2
    moved = [([[1, 0]], [np.nextafter(0.0, 1.0)]), ([[-1, 0]], [0.0])]
    system(moved)
    assert len(calls) == 3
    with pytest.raises(ModelError) as info:  # the overlap of the moved guard is below the tolerance; OVERLAP is not
        system(OVERLAP)
    assert "g0, g1" in str(info.value) and len(calls) == 4
    monkeypatch.setattr(pwa, "_PARTITION_OUTCOMES_MAX", 2)
    for k in range(3):
        system([([[1, 0]], [0.1 * k]), ([[-1, 0]], [-0.1 * k])])
    assert len(pwa._PARTITION_OUTCOMES) == 2


# ------------------------------------------------------------------ the proof's fast interior test

def _scipy_chebyshev_radius(P, scale):
    """The Chebyshev radius of ``P`` in ``z / scale`` by scipy's linprog (HiGHS through scipy, not
    the toolbox's LP layer): the oracle of the certified slack-LP decisions."""
    from scipy.optimize import linprog

    A = P.A * scale[None, :]
    norms = np.linalg.norm(A, axis=1)
    res = linprog(np.r_[np.zeros(P.dim), -1.0], A_ub=np.c_[A, norms], b_ub=P.b,
                  bounds=[(None, None)] * P.dim + [(None, 1.0)], method="highs")
    assert res.status in (0, 2), res.message
    return -np.inf if res.status == 2 else float(res.x[-1])


def _proof_sets(sys_, monkeypatch):
    """Every set the partition proof of ``sys_`` asks the fast test about, with its decision."""
    import hybobs_opt.systems.pwa as pwa

    seen = []
    original = pwa._interior_by_slack_lp

    def spy(P, scale, radius_bound):
        decided = original(P, scale, radius_bound)
        seen.append((P, scale.copy(), decided))
        return decided

    monkeypatch.setattr(pwa, "_interior_by_slack_lp", spy)
    monkeypatch.setattr(pwa, "_PARTITION_OUTCOMES", type(pwa._PARTITION_OUTCOMES)())
    try:
        pwa.check_partition(sys_)
    except ModelError:
        pass
    return seen


def test_the_proofs_fast_interior_decisions_agree_with_scipy(monkeypatch):
    """Every decision the certified slack LP takes in the partition proofs of both powertrains and
    of the oracle's random partitions equals the Chebyshev radius from scipy's linprog compared
    with the tolerance; the flat sets of shared boundaries are among them (and decided)."""
    from hybobs_opt.studies.paper002_powertrain.systems import powertrain3, powertrain5
    from hybobs_opt.tolerances import FULL_DIMENSION_RTOL

    systems = [powertrain3(), powertrain5()] + [system(guards, partition="none") for guards in INSTANCES[:10]]
    counts = {True: 0, False: 0, None: 0}
    flat = 0
    for sys_ in systems:
        for P, scale, decided in _proof_sets(sys_, monkeypatch):
            counts[decided] += 1
            r = _scipy_chebyshev_radius(P, scale)
            flat += decided is False and abs(r) < 1e-12
            if decided is not None:
                assert decided == (r > FULL_DIMENSION_RTOL), (decided, r)
    assert counts[True] > 0 and counts[False] > 0 and flat > 0, (counts, flat)


@pytest.mark.parametrize("half_width, expected", [
    (0.0, False), (1e-9, False), (0.5e-7, False), (0.999e-7, None), (1.0e-7, None), (1.001e-7, None),
    (2e-7, True), (1e-3, True), (-1e-3, False),
])
def test_the_fast_interior_test_decides_thin_slabs_only_with_a_margin(half_width, expected):
    """A slab ``|x1| <= h`` of the unit box (scale 1): radius ``h`` in ``z / scale``, decided only when
    it clears the threshold by the margin; the near-threshold slabs go to the exact path (None)."""
    import hybobs_opt.systems.pwa as pwa

    slab = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
                    np.array([half_width, half_width, 0.5, 0.5]))
    decided = pwa._interior_by_slack_lp(slab, np.ones(2), float(np.sqrt(0.5)) * 1.01)
    if expected is None:
        assert decided is None
    else:
        assert decided is expected

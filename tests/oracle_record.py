"""Recorded verdicts of the exact oracle (:mod:`exact_oracle`), re-checked live.

The MILP oracle costs 20-270 ms per state; the agreement tests ask it about thousands of states,
which was a third of the suite's time.  Its verdicts are therefore recorded once per
configuration in ``tests/oracle_records/NAME.json`` and used as follows (``HYBOBS_ORACLE``):

``recorded`` (default, ``make test``)
    A state found in the record (scaled inf-distance <= :data:`MATCH_TOL` from a recorded state)
    gets its recorded verdict; every :data:`LIVE_EVERY`-th recorded state, every state not in
    the record and every state whose toolbox answer lies outside its recorded verdict are decided
    by the live oracle, and a live verdict that shares no answer with the record fails the test
    (:class:`StaleRecord`); one that overlaps it (a state within the oracle's margins, which
    another CPU's rounding may decide otherwise) replaces it and is counted.  A toolbox answer is
    therefore never judged against a record that the oracle does not confirm.
``live`` (the CI step after ``make test``)
    Every verdict is computed by the live oracle and checked against the record the same way.
``record``
    Every verdict is computed live and the file is (re)written.  Needed after a change of
    ``exact_oracle.py`` or of the system: the record names both (sha256 of the oracle's source,
    the system's raw data), and a record whose oracle or system differs is not used at all
    (every verdict live, and a warning saying how to re-record).

Why a match within ``MATCH_TOL = 1e-10`` (scaled) may reuse a verdict: the oracle decides with
margins of at least ``MARGIN = 1e-7`` on every region row and ``delta / 10 = 1e-5`` on
distances, so moving a state by 1e-10 shifts a witness ``x^`` by the same amount and keeps it
(same mode sequences, outputs moved together, rows within 1e-10 of their old slack); a state
that close to a margin is one the live spot checks would show as changed.  The tolerance lets
a trace simulated on another CPU (equal to a few ulps) reuse the record.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from pathlib import Path

import numpy as np

import exact_oracle

RECORDS = Path(__file__).resolve().parent / "oracle_records"
ORACLE_SOURCE = Path(exact_oracle.__file__)
MATCH_TOL = 1e-10
LIVE_EVERY = 8
MODES = ("recorded", "live", "record")
FORMAT = 1


class StaleRecord(AssertionError):
    """A recorded verdict that the live oracle does not give again."""


class RecordedVerdict:
    """A verdict read from the record: ``label`` and ``allowed`` as the oracle's :class:`Verdict`."""

    def __init__(self, label: str, allowed, index: int):
        self.label, self.allowed, self.index = label, frozenset(allowed), index
        self.reason = f"recorded verdict #{index}"


def mode() -> str:
    value = os.environ.get("HYBOBS_ORACLE", "recorded")
    if value not in MODES:
        raise ValueError(f"HYBOBS_ORACLE must be one of {MODES}, got {value!r}")
    return value


def oracle_digest() -> str:
    return hashlib.sha256(ORACLE_SOURCE.read_bytes()).hexdigest()


def system_data(system) -> np.ndarray:
    """The raw data the oracle reads (see :mod:`exact_oracle`), as one vector."""
    parts = []
    for md in system.modes:
        parts += [md.A, md.B, md.a, md.C, md.D, md.c, md.guard.A, md.guard.b]
    parts += [system.state_bounds.A, system.state_bounds.b, system.input_bounds.A, system.input_bounds.b]
    parts += list(system.scales())
    return np.concatenate([np.asarray(p, float).ravel() for p in parts])


def render(identity: dict, system: np.ndarray, keys, labels, allowed) -> str:
    """The record's JSON text: one line per verdict (``[key, label, allowed]``), so that a
    re-recording shows in ``git diff`` as the verdicts it changed."""
    head = {**identity, "match_tol": MATCH_TOL, "system": [float(v) for v in system]}
    rows = ",\n".join(json.dumps([list(map(float, k)), lab, list(al)]) for k, lab, al in zip(keys, labels, allowed))
    return json.dumps(head)[:-1] + ',\n"verdicts": [\n' + rows + "\n]}\n"


class OracleRecord:
    """The oracle's verdicts on one configuration: ``verdict(key)`` for a key vector.

    Parameters
    ----------
    name : str
        File name (``tests/oracle_records/NAME.json``).
    system : PWASystem
        The system the oracle is asked about.
    T : int
        Horizon.
    kind : {"state", "window"}
        ``"state"``: :func:`exact_oracle.analyse_state` on ``key = x``; ``"window"``:
        :func:`exact_oracle.analyse_window` on ``key = (x, U.ravel())``.
    scale : array
        Per key entry, the length that :data:`MATCH_TOL` is relative to (the state's and the
        inputs' half ranges).
    options : dict
        Keyword arguments of the oracle call (delta, margin, ...); part of the record's identity.
    """

    def __init__(self, name: str, system, T: int, kind: str, scale, options: dict | None = None):
        if kind not in ("state", "window"):
            raise ValueError(kind)
        self.name, self.system, self.T, self.kind = name, system, T, kind
        self.scale = np.asarray(scale, float)
        self.options = dict(options or {})
        self.path = RECORDS / f"{name}.json"
        self.mode = mode()
        self.counts = {"recorded": 0, "live": 0, "spot_checks": 0, "not_in_record": 0, "disagreement_checks": 0,
                       "changed": 0}
        self.keys = np.zeros((0, self.scale.size))
        self.entries: list[tuple[str, frozenset]] = []
        self.usable = False
        self._new: list[tuple[np.ndarray, str, frozenset]] = []
        if self.mode != "record":
            self._load()

    # ------------------------------------------------------------------ file
    def _identity(self) -> dict:
        return {"format": FORMAT, "oracle_sha256": oracle_digest(), "T": self.T, "kind": self.kind,
                "options": {k: self.options[k] for k in sorted(self.options)}}

    def _load(self) -> None:
        if not self.path.exists():
            warnings.warn(f"{self.path.name}: no recorded oracle verdicts; every verdict is live "
                          f"(write them with HYBOBS_ORACLE=record)", stacklevel=3)
            return
        data = json.loads(self.path.read_text())
        ident = self._identity()
        same = all(data.get(k) == v for k, v in ident.items())
        rec_sys = np.asarray(data.get("system", []), float)
        now = system_data(self.system)
        same_system = rec_sys.shape == now.shape and np.allclose(rec_sys, now, rtol=1e-12,
                                                                    atol=1e-12 * max(1.0, np.abs(now).max()))
        if not (same and same_system):
            what = "the oracle's source or its options" if not same else "the system's data"
            warnings.warn(f"{self.path.name}: recorded for other {what}; every verdict is live "
                          f"(re-record with HYBOBS_ORACLE=record)", stacklevel=3)
            return
        rows = data["verdicts"]
        self.keys = np.asarray([k for k, _, _ in rows], float).reshape(-1, self.scale.size)
        self.entries = [(lab, frozenset(al)) for _, lab, al in rows]
        self._index = {k.tobytes(): i for i, k in enumerate(self.keys)}
        self.usable = True

    def save(self) -> None:
        """Write the verdicts computed in ``record`` mode (no-op in the other modes)."""
        if self.mode != "record":
            return
        order = sorted(range(len(self._new)), key=lambda i: tuple(self._new[i][0]))
        seen, keys, labels, allowed = set(), [], [], []
        for i in order:
            k, lab, al = self._new[i]
            if k.tobytes() in seen:
                continue
            seen.add(k.tobytes())
            keys.append([float(v) for v in k])
            labels.append(lab)
            allowed.append(sorted(al))
        RECORDS.mkdir(exist_ok=True)
        self.path.write_text(render(self._identity(), system_data(self.system), keys, labels, allowed))

    # ------------------------------------------------------------------ verdicts
    def _find(self, key: np.ndarray) -> int | None:
        if not self.usable:
            return None
        i = self._index.get(key.tobytes())
        if i is not None:
            return i
        if not len(self.keys):
            return None
        d = np.max(np.abs(self.keys - key) / self.scale, axis=1)
        j = int(np.argmin(d))
        return j if d[j] <= MATCH_TOL else None

    def _live(self, key: np.ndarray):
        self.counts["live"] += 1
        n = self.system.n
        if self.kind == "state":
            v = exact_oracle.analyse_state(self.system, self.T, key[:n], **self.options)
        else:
            v = exact_oracle.analyse_window(self.system, self.T, key[:n], key[n:].reshape(self.T, -1), **self.options)
        if self.mode == "record":
            self._new.append((key.copy(), v.label, frozenset(v.allowed)))
        return v

    def _confirm(self, key, i: int, why: str):
        """The live verdict on recorded entry ``i``: a live ``allowed`` set that shares no answer
        with the recorded one is a wrong record (:class:`StaleRecord`); one that overlaps it but
        differs (a state within the oracle's margins, decided otherwise by another CPU's
        rounding) is counted and used in its place."""
        v = self._live(key)
        label, allowed = self.entries[i]
        if frozenset(v.allowed).isdisjoint(allowed):
            raise StaleRecord(f"{self.path.name}: recorded verdict #{i} ({label}, {sorted(allowed)}) at key "
                              f"{key.tolist()} is not the live oracle's ({v.label}, {sorted(v.allowed)}; {v.reason}) "
                              f"[{why}]: re-record with HYBOBS_ORACLE=record")
        if (v.label, frozenset(v.allowed)) != (label, allowed):
            self.counts["changed"] += 1
        return v

    def verdict(self, key, toolbox=None):
        """The oracle's verdict on ``key``.

        ``toolbox``: the answer under test, a label or the collection of labels consistent with
        it; a recorded verdict whose ``allowed`` set has none of them is confirmed live before
        it is used.
        """
        key = np.asarray(key, float).ravel()
        if isinstance(toolbox, str):
            toolbox = (toolbox,)
        i = None if self.mode == "record" else self._find(key)
        if i is None:
            if self.mode == "recorded":
                self.counts["not_in_record"] += 1
            return self._live(key)
        if self.mode == "live":
            return self._confirm(key, i, "live mode")
        label, allowed = self.entries[i]
        if toolbox is not None and allowed.isdisjoint(toolbox):
            self.counts["disagreement_checks"] += 1
            return self._confirm(key, i, "the toolbox disagrees")
        if i % LIVE_EVERY == 0:
            self.counts["spot_checks"] += 1
            return self._confirm(key, i, "spot check")
        self.counts["recorded"] += 1
        return RecordedVerdict(label, allowed, i)

    def summary(self) -> str:
        c = self.counts
        return (f"oracle {self.mode}: {c['recorded']} recorded verdicts used, {c['live']} live "
                f"({c['spot_checks']} spot checks, {c['not_in_record']} not in the record, "
                f"{c['disagreement_checks']} toolbox disagreements re-decided; {c['changed']} live verdicts differ from "
                f"the record within the oracle's margins)")

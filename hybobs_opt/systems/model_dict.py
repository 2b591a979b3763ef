"""Systems as plain dictionaries: ``to_dict`` / ``from_dict`` of every system class.

The dictionary is the content of a model file (:mod:`hybobs_opt.systems.model_file`; the JSON
Schema is ``hybobs_opt/systems/model.schema.json``).  It holds only strings, numbers, lists and
mappings, never ``null`` (so TOML can hold it too): matrices are nested lists (row by row), sets
are H-form ``{"A", "b"}`` (or, when written by hand, a ``"box"`` of named intervals and/or
``"inequalities"`` over named variables), and nonlinear functions are expressions over named
variables (:mod:`hybobs_opt.systems.expressions`).

``from_dict(to_dict(s))`` rebuilds ``s`` exactly: the same arrays (bit for bit), names and
expression trees; ``to_dict`` of the rebuilt system is the same dictionary.

Top-level keys common to every class: ``format`` (``"hybobs-model"``), ``version``, ``class``
(one of :data:`CLASSES`), ``name``, ``states``, ``inputs``, ``outputs``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import casadi as ca
import numpy as np

from ..errors import ModelError
from .expressions import affine_coefficients, parse_expression, parse_vector, trace_callable, vector_texts
from ..geometry.polytope import Polytope

FORMAT = "hybobs-model"
VERSION = 1
#: The ``class`` value of each system class.
MODEL_CLASSES: dict[str, str] = {"PWASystem": "pwa", "HybridAutomaton": "hybrid_automaton",
                                 "ConstantDriftSystem": "constant_drift", "ScalarNonlinearSystem": "scalar_nonlinear"}
#: ``class`` values.
CLASSES = tuple(MODEL_CLASSES.values())


def model_class(system: Any) -> str:
    """The model-file ``class`` of ``system`` (``"pwa"``, ...); its type name for anything else."""
    return MODEL_CLASSES.get(type(system).__name__, type(system).__name__)


#: Where the classes this module builds live.  They import this module (through ``to_dict``), so
#: it looks them up by name when it needs them instead of importing them at the top.
_CLASS_MODULES: dict[str, str] = {
    "PWASystem": "pwa", "PWAMode": "pwa", "HybridAutomaton": "hybrid", "Location": "hybrid", "Edge": "hybrid",
    "ConstantDriftSystem": "constant_drift", "ScalarNonlinearSystem": "scalar_nonlinear",
    "ScalarFunction": "scalar_nonlinear",
}


def _cls(name: str) -> type:
    import importlib

    return getattr(importlib.import_module(f"{__package__}.{_CLASS_MODULES[name]}"), name)


# ---------------------------------------------------------------------------------- entry points

def system_to_dict(system: Any) -> dict[str, Any]:
    """The model dictionary of a PWA system, hybrid automaton, constant-drift or scalar-nonlinear system."""
    writers = {"PWASystem": _pwa_to_dict, "HybridAutomaton": _hybrid_to_dict,
               "ConstantDriftSystem": _drift_to_dict, "ScalarNonlinearSystem": _nonlinear_to_dict}
    for name, writer in writers.items():
        if isinstance(system, _cls(name)):
            return {"format": FORMAT, "version": VERSION, **writer(system)}
    raise ModelError("system", "a PWASystem, HybridAutomaton, ConstantDriftSystem or ScalarNonlinearSystem",
                     type(system).__name__)


def system_from_dict(data: Mapping[str, Any]) -> Any:
    """Build the system a model dictionary describes; ``ModelError`` names the entry at fault."""
    if not isinstance(data, Mapping):
        raise ModelError("model", "a mapping (a JSON object / TOML table)", type(data).__name__)
    if data.get("format", FORMAT) != FORMAT:
        raise ModelError("format", repr(FORMAT), repr(data.get("format")))
    version = data.get("version", VERSION)
    if version != VERSION:
        raise ModelError("version", f"{VERSION} (the model format this hybobs_opt reads)", repr(version))
    kind = data.get("class")
    readers = {"pwa": _pwa_from_dict, "hybrid_automaton": _hybrid_from_dict,
               "constant_drift": _drift_from_dict, "scalar_nonlinear": _nonlinear_from_dict}
    if not isinstance(kind, str) or kind not in readers:
        raise ModelError("class", f"one of {list(CLASSES)}", repr(kind))
    reader = _Reader(data)
    reader.check_keys(_COMMON_KEYS | _CLASS_KEYS[kind])
    return readers[kind](reader)


_COMMON_KEYS = frozenset({"format", "version", "class", "name", "states", "inputs", "outputs"})
#: The keys of each class (besides :data:`_COMMON_KEYS`) and of the tables inside.
_CLASS_KEYS = {
    "pwa": frozenset({"Ts", "state_bounds", "input_bounds", "partition", "modes"}),
    "hybrid_automaton": frozenset({"state_bounds", "input_bounds", "locations", "edges"}),
    "constant_drift": frozenset({"modes", "f", "trigger", "alpha", "h"}),
    "scalar_nonlinear": frozenset({"box", "A", "B", "F", "E", "f", "C", "h", "g"}),
}
_MODE_KEYS = frozenset({"name", "A", "B", "a", "C", "D", "c", "guard"})
_LOCATION_KEYS = frozenset({"name", "invariant", "A", "B", "E", "flow", "C", "D", "c", "output"})
_EDGE_KEYS = frozenset({"source", "target", "guard", "reset"})
_FUNCTION_KEYS = frozenset({"name", "expr", "derivative", "argument"})


# ---------------------------------------------------------------------------------- reading helpers

class _Reader:
    """Typed access to the entries of a model dictionary, each error naming its entry."""

    def __init__(self, data: Mapping[str, Any], prefix: str = ""):
        self.data, self.prefix = data, prefix

    def at(self, key: str) -> str:
        return f"{self.prefix}{key}"

    def has(self, key: str) -> bool:
        return key in self.data

    def check_keys(self, allowed: set[str] | frozenset[str]) -> None:
        """Refuse an unknown key (a misspelt ``BB`` would otherwise read as a missing ``B = 0``);
        keys that begin with ``_`` are comments (JSON has no other kind)."""
        unknown = sorted(k for k in self.data if not (isinstance(k, str) and k.startswith("_")) and k not in allowed)
        if unknown:
            raise ModelError(self.at(unknown[0]), f"one of the keys {sorted(allowed)} (or a comment key starting with '_')",
                             "an unknown key")

    def raw(self, key: str, default: Any = ...) -> Any:
        if key not in self.data:
            if default is ...:
                raise ModelError(self.at(key), "present", "missing")
            return default
        return self.data[key]

    def sub(self, key: str) -> "_Reader":
        value = self.raw(key)
        if not isinstance(value, Mapping):
            raise ModelError(self.at(key), "a mapping (table)", type(value).__name__)
        return _Reader(value, f"{self.at(key)}.")

    def items(self, key: str, default: Any = ...) -> list["_Reader"]:
        value = self.raw(key, default)
        if value is default and default is not ...:
            return value
        if not isinstance(value, Sequence) or isinstance(value, (str, bytes)):
            raise ModelError(self.at(key), "a list of tables", type(value).__name__)
        out = []
        for i, item in enumerate(value):
            if not isinstance(item, Mapping):
                raise ModelError(f"{self.at(key)}[{i}]", "a mapping (table)", type(item).__name__)
            out.append(_Reader(item, f"{self.at(key)}[{i}]."))
        return out

    def string(self, key: str, default: Any = ...) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str):
            raise ModelError(self.at(key), "a string", type(value).__name__)
        return value

    def names(self, key: str) -> tuple[str, ...]:
        """Names normalised to NFKC, as Python's parser reads the names in expressions (``𝐱`` is
        ``x`` there): two names that normalise to the same one are refused, not merged."""
        import unicodedata

        value = self.raw(key, [])
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or not all(isinstance(v, str) for v in value):
            raise ModelError(self.at(key), "a list of names (strings)", repr(value))
        out = tuple(unicodedata.normalize("NFKC", v) for v in value)
        seen: dict[str, str] = {}
        for raw, name in zip(value, out):
            if name in seen:
                raise ModelError(self.at(key), "distinct names (compared after NFKC normalisation, as in expressions)",
                                 f"{seen[name]!r} and {raw!r} are both {name!r}")
            seen[name] = raw
        return out

    def number(self, key: str, default: Any = ...) -> float:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ModelError(self.at(key), "a finite number", repr(value))
        return float(value)

    def matrix(self, key: str, shape: tuple[int | None, int | None], default: Any = ...) -> np.ndarray:
        value = self.raw(key, default)
        if value is default and default is not ...:
            return value
        return _matrix(value, self.at(key), shape)

    def vector(self, key: str, size: int | None, default: Any = ...) -> np.ndarray:
        value = self.raw(key, default)
        if value is default and default is not ...:
            return value
        return _vector(value, self.at(key), size)


def _numbers(value: Any, field: str) -> np.ndarray:
    def check(v):
        if isinstance(v, str):
            # a constant written as an expression ("pi", "0.8*cos(pi/3)", YAML's unquoted "1e-3")
            c = parse_expression(v, {}, field)
            if not c.is_constant():
                raise ModelError(field, "numbers or constant expressions", repr(v))
            return float(c)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ModelError(field, "numbers or constant expressions such as 'pi/3' (nested lists for a matrix)", repr(v))
        return float(v)

    leaves = _walk(value, check)  # a bad entry raises here, naming itself
    try:
        arr = np.array(leaves, dtype=float)
    except ValueError:
        raise ModelError(field, "a rectangular nested list of numbers", "rows of different lengths") from None
    if not np.all(np.isfinite(arr)):
        raise ModelError(field, "finite numbers", "NaN or infinity")
    return arr


def _walk(value, leaf):
    if isinstance(value, (list, tuple)):
        return [_walk(v, leaf) for v in value]
    return leaf(value)


def _matrix(value: Any, field: str, shape: tuple[int | None, int | None]) -> np.ndarray:
    arr = _numbers(value, field)
    rows, cols = shape
    if arr.ndim == 1 and arr.size == 0:
        arr = arr.reshape(rows or 0, cols or 0) if (rows or 0) * (cols or 0) == 0 else arr
    if arr.ndim != 2:
        raise ModelError(field, f"a matrix as a list of rows{_shape_text(shape)}", f"{arr.ndim} nesting level(s)")
    if (rows is not None and arr.shape[0] != rows) or (cols is not None and arr.shape[1] != cols):
        raise ModelError(field, f"a matrix{_shape_text(shape)}", f"shape {arr.shape}")
    return arr


def _shape_text(shape) -> str:
    rows, cols = shape
    return f" of shape ({'any' if rows is None else rows}, {'any' if cols is None else cols})"


def _vector(value: Any, field: str, size: int | None) -> np.ndarray:
    arr = _numbers(value, field)
    if arr.ndim != 1 or (size is not None and arr.size != size):
        raise ModelError(field, f"a list of {'' if size is None else size} numbers".replace("  ", " "), f"shape {arr.shape}")
    return arr


def _matrix_list(a: np.ndarray) -> list:
    return np.asarray(a, dtype=float).tolist()


# ---------------------------------------------------------------------------------- sets

def polytope_to_dict(poly: Polytope) -> dict[str, Any]:
    """``{"A": rows, "b": list, "names": list}`` (H-form, exact)."""
    out: dict[str, Any] = {"A": _matrix_list(poly.A), "b": _matrix_list(poly.b)}
    if poly.dim and poly.A.shape[0] == 0:
        out["dim"] = poly.dim
    out["names"] = list(poly.names)
    return out


def polytope_from_dict(value: Any, spaces: Sequence[tuple[str, ...]], field: str) -> Polytope:
    """A set of a model file over the first of ``spaces`` (tuples of variable names) it fits.

    ``value`` holds any of: ``"A"``/``"b"`` (H-form; its column count picks the space),
    ``"box"`` (``{name: [lower, upper]}``, a name may be left out), ``"inequalities"``
    (strings ``"expr <= expr"`` or ``"expr >= expr"``, affine in the named variables);
    together they are intersected.  ``"names"`` (optional) names the coordinates.
    """
    if not isinstance(value, Mapping):
        raise ModelError(field, "a set: a mapping with 'A' and 'b', a 'box' or 'inequalities'", type(value).__name__)
    unknown = {k for k in value if not str(k).startswith("_")} - {"A", "b", "box", "inequalities", "names", "dim"}
    if unknown:
        raise ModelError(field, "the keys A, b, box, inequalities, names", f"unknown key(s) {sorted(unknown)}")
    if not ({"A", "b", "box", "inequalities"} & set(value)):
        raise ModelError(field, "a set: 'A' and 'b', a 'box' or 'inequalities'", "none of them")
    mentioned: set[str] = set()
    if "box" in value:
        if not isinstance(value["box"], Mapping):
            raise ModelError(f"{field}.box", "a mapping {name: [lower, upper]}", type(value["box"]).__name__)
        mentioned |= set(value["box"])
    texts = value.get("inequalities", [])
    if isinstance(texts, (str, bytes)) or not isinstance(texts, Sequence):
        raise ModelError(f"{field}.inequalities", "a list of strings like 'theta <= 0.03'", type(texts).__name__)
    space = None
    if "A" in value or "b" in value:
        if "A" not in value or "b" not in value:
            raise ModelError(field, "both 'A' and 'b' for an H-form set", f"only {'A' if 'A' in value else 'b'}")
        b = _vector(value["b"], f"{field}.b", None)
        if b.size == 0:
            dim = value.get("dim")
            if isinstance(dim, bool) or not isinstance(dim, int):
                raise ModelError(f"{field}.dim", "the dimension (an integer) of a set with no rows", repr(dim))
            cols = dim
        else:
            cols = _matrix(value["A"], f"{field}.A", (b.size, None)).shape[1]
        space = next((s for s in spaces if len(s) == cols), None)
        if space is None:
            raise ModelError(f"{field}.A", f"{' or '.join(str(len(s)) for s in spaces)} columns (one per variable of "
                             f"{' or '.join(str(list(s)) for s in spaces)})", f"{cols}")
    else:
        for s in spaces:
            ok = set(s)
            if mentioned <= ok and all(_names_in(t, ok) for t in texts if isinstance(t, str)):
                space = s
                break
        if space is None:
            space = spaces[-1]
    names = value.get("names", space if len(set(space)) == len(space) else ())
    if isinstance(names, (str, bytes)) or not isinstance(names, (list, tuple)):
        raise ModelError(f"{field}.names", "a list of coordinate names", repr(names))
    d = len(space)
    rows, rhs = [], []
    if "A" in value:
        A = _matrix(value["A"], f"{field}.A", (None, d)) if np.size(value["b"]) else np.zeros((0, d))
        rows.append(A)
        rhs.append(_vector(value["b"], f"{field}.b", A.shape[0]))
    if "box" in value:
        # rows as Polytope.from_box writes them: every upper bound, then every lower bound, in
        # the order of the variables (so a box written by hand is the same polytope, row for row)
        bounds = {}
        for name, interval in value["box"].items():
            if name not in space:
                raise ModelError(f"{field}.box", f"intervals of the variables {list(space)}", f"the unknown name {name!r}")
            lo_hi = _vector(interval, f"{field}.box.{name}", 2)
            if not lo_hi[0] <= lo_hi[1]:
                raise ModelError(f"{field}.box.{name}", "[lower, upper] with lower <= upper", f"{lo_hi.tolist()}")
            bounds[space.index(name)] = lo_hi
        ks = sorted(bounds)
        rows.append(np.vstack([np.eye(d)[ks], -np.eye(d)[ks]]))
        rhs.append(np.array([bounds[k][1] for k in ks] + [-bounds[k][0] for k in ks]))
    if texts:
        symbols = ca.vertcat(*[ca.SX.sym(v) for v in space])
        variables = {v: symbols[i] for i, v in enumerate(space)}
        for i, text in enumerate(texts):
            a, c = _inequality(text, variables, symbols, f"{field}.inequalities[{i}]")
            rows.append(a[None, :])
            rhs.append(np.array([c]))
    A = np.vstack(rows) if rows else np.zeros((0, d))
    b = np.concatenate(rhs) if rhs else np.zeros(0)
    try:
        return Polytope(A, b, names)
    except ModelError as exc:
        raise ModelError(f"{field}.{exc.field}", exc.expected, exc.got) from None


def _names_in(text: str, allowed: set[str]) -> bool:
    import ast

    from .expressions import MAX_EXPRESSION_CHARS

    if len(text) > MAX_EXPRESSION_CHARS:
        return True  # the parser refuses it with the entry's name, before parsing
    try:
        tree = ast.parse(text, mode="eval")
    except (SyntaxError, RecursionError, MemoryError):
        return True  # the parser reports it with the entry's name
    from .expressions import CONSTANTS, FUNCTIONS

    return all(n.id in allowed or n.id in CONSTANTS or n.id in FUNCTIONS for n in ast.walk(tree) if isinstance(n, ast.Name))


def _inequality(text: Any, variables: dict, symbols: ca.SX, field: str) -> tuple[np.ndarray, float]:
    """``a . z <= c`` from ``"lhs <= rhs"`` or ``"lhs >= rhs"`` (affine sides)."""
    if not isinstance(text, str):
        raise ModelError(field, "a string like 'theta - 0.5 * omega <= 0.03'", type(text).__name__)
    for op, sign in (("<=", 1.0), (">=", -1.0)):
        if text.count(op) == 1 and "==" not in text:
            lhs, rhs = text.split(op)
            diff = sign * (parse_expression(lhs, variables, field) - parse_expression(rhs, variables, field))
            a, c = affine_coefficients(diff, symbols, field)
            if not np.any(a):
                raise ModelError(field, "an inequality that involves at least one variable", repr(text))
            return a, -c
    raise ModelError(field, "one '<=' or '>=' between two affine expressions", repr(text))


# ---------------------------------------------------------------------------------- PWA

def _names_and_bounds(r: _Reader):
    """``states, inputs, outputs, X, U`` of a PWA system or hybrid automaton (``U`` None without inputs)."""
    states, inputs, outputs = r.names("states"), r.names("inputs"), r.names("outputs")
    if not states:
        raise ModelError("states", "the names of the states (at least one)", "an empty list")
    X = polytope_from_dict(r.raw("state_bounds"), [states], "state_bounds")
    U = polytope_from_dict(r.raw("input_bounds"), [inputs], "input_bounds") if r.has("input_bounds") else None
    if inputs and U is None:
        raise ModelError("input_bounds", f"a bounded set over the inputs {list(inputs)}", "missing")
    return states, inputs, outputs, X, U


def _pwa_to_dict(s) -> dict[str, Any]:
    out: dict[str, Any] = {"class": "pwa", "name": s.name, "states": list(s.state_names),
                           "inputs": list(s.input_names), "outputs": list(s.output_names)}
    if s.Ts is not None:
        out["Ts"] = float(s.Ts)
    out["state_bounds"] = polytope_to_dict(s.state_bounds)
    if s.input_bounds is not None:
        out["input_bounds"] = polytope_to_dict(s.input_bounds)
    out["partition"] = s.partition
    out["modes"] = [{"name": m.name, "A": _matrix_list(m.A), "B": _matrix_list(m.B), "a": _matrix_list(m.a),
                     "C": _matrix_list(m.C), "D": _matrix_list(m.D), "c": _matrix_list(m.c),
                     "guard": polytope_to_dict(m.guard)} for m in s.modes]
    return out


def _pwa_from_dict(r: _Reader):
    PWAMode, PWASystem = _cls("PWAMode"), _cls("PWASystem")
    states, inputs, outputs, X, U = _names_and_bounds(r)
    n, m = len(states), len(inputs)
    p = len(outputs) if outputs else None
    modes = []
    for i, mr in enumerate(r.items("modes")):
        mr.check_keys(_MODE_KEYS)
        C = mr.matrix("C", (p, n))
        p = C.shape[0]
        modes.append(PWAMode(
            A=mr.matrix("A", (n, n)), B=mr.matrix("B", (n, m), np.zeros((n, m))), a=mr.vector("a", n, np.zeros(n)),
            C=C, D=mr.matrix("D", (p, m), np.zeros((p, m))), c=mr.vector("c", p, np.zeros(p)),
            guard=polytope_from_dict(mr.raw("guard"), [states + inputs], mr.at("guard")),
            name=mr.string("name", f"mode{i}")))
    Ts = r.number("Ts") if r.has("Ts") else None
    return PWASystem(tuple(modes), X, U, states, inputs, outputs, Ts=Ts, name=r.string("name", "pwa"),
                     partition=r.string("partition", "check"))


# ---------------------------------------------------------------------------------- hybrid automaton

def _symbols(names: Sequence[str], field: str) -> tuple[ca.SX, dict[str, ca.SX]]:
    for name in names:
        if not name.isidentifier():
            raise ModelError(field, "variable names that are identifiers (letters, digits, _), to be used in expressions",
                             repr(name))
    vec = ca.vertcat(*[ca.SX.sym(v) for v in names]) if names else ca.SX.zeros(0, 1)
    return vec, {v: vec[i] for i, v in enumerate(names)}


class ExpressionMap:
    """A vector function of named variables given by expressions, callable on numbers or symbols.

    Built by model files for flows ``flow(x, u)``, outputs ``output(x, u)`` and ``g(y, u)``.
    Called with numpy arrays it returns a flat float array; called with CasADi symbols it returns
    the ``SX`` expression (so the function can be written back as text exactly).
    """

    def __init__(self, texts: Sequence[Any], groups: Sequence[Sequence[str]], field: str, size: int):
        symbols, variables = [], {}
        for g in groups:
            vec, names = _symbols(g, field)
            symbols.append(vec)
            variables.update(names)
        self.expr = parse_vector(texts, variables, field, size)
        self.texts = vector_texts(self.expr, field)
        self._fn = ca.Function("expression_map", symbols, [self.expr])
        self.size = size

    def __call__(self, *args):
        if any(isinstance(a, (ca.SX, ca.MX)) for a in args):
            return self._fn(*args)
        return np.asarray(self._fn(*(np.asarray(a, dtype=float) for a in args)), dtype=float).reshape(self.size)


def _callable_texts(fn, groups: Sequence[Sequence[str]], size: int, field: str) -> list[str]:
    if isinstance(fn, ExpressionMap):
        return list(fn.texts)
    args = [_symbols(g, field)[0] for g in groups]
    return vector_texts(trace_callable(fn, args, size, field), field)


def _hybrid_to_dict(s) -> dict[str, Any]:
    xu = (s.state_names, s.input_names)
    out: dict[str, Any] = {"class": "hybrid_automaton", "name": s.name, "states": list(s.state_names),
                           "inputs": list(s.input_names), "outputs": list(s.output_names),
                           "state_bounds": polytope_to_dict(s.state_bounds)}
    if s.input_bounds is not None:
        out["input_bounds"] = polytope_to_dict(s.input_bounds)
    locations = []
    for i, loc in enumerate(s.locations):
        f = f"locations[{i}]"
        item: dict[str, Any] = {"name": loc.name, "invariant": polytope_to_dict(loc.invariant)}
        if loc.A is not None:
            item.update(A=_matrix_list(loc.A), B=_matrix_list(loc.B), E=_matrix_list(loc.E))
        else:
            item["flow"] = _callable_texts(loc.flow, xu, s.n, f"{f}.flow")
        if loc.C is not None:
            item.update(C=_matrix_list(loc.C), D=_matrix_list(loc.D), c=_matrix_list(loc.c))
        else:
            item["output"] = _callable_texts(loc.output, xu, s.p, f"{f}.output")
        locations.append(item)
    out["locations"] = locations
    edges = []
    for e in s.edges:
        item = {"source": e.source, "target": e.target}
        if e.guard is not None:
            item["guard"] = polytope_to_dict(e.guard)
        if e.reset is not None:
            item["reset"] = {"R": _matrix_list(e.reset[0]), "r": _matrix_list(e.reset[1])}
        edges.append(item)
    out["edges"] = edges
    return out


def _hybrid_from_dict(r: _Reader):
    Edge, HybridAutomaton, Location = _cls("Edge"), _cls("HybridAutomaton"), _cls("Location")
    states, inputs, outputs, X, U = _names_and_bounds(r)
    n, m = len(states), len(inputs)
    p = len(outputs) if outputs else None
    locs, names = [], []
    readers = r.items("locations")
    if p is None:
        first = next((lr for lr in readers if lr.has("C")), None)
        if first is not None:
            p = first.matrix("C", (None, n)).shape[0]
        elif readers:
            texts = readers[0].raw("output", [])
            if isinstance(texts, (str, bytes)) or not isinstance(texts, Sequence):
                raise ModelError(readers[0].at("output"), "a list of expressions, one per output", type(texts).__name__)
            p = len(texts)
        else:
            p = 0
    for i, lr in enumerate(readers):
        lr.check_keys(_LOCATION_KEYS)
        name = lr.string("name", f"location{i}")
        names.append(name)
        inv = polytope_from_dict(lr.raw("invariant"), [states, states + inputs], lr.at("invariant"))
        kw: dict[str, Any] = {}
        if lr.has("flow"):
            kw["flow"] = ExpressionMap(lr.raw("flow"), (states, inputs), lr.at("flow"), n)
        else:
            kw.update(A=lr.matrix("A", (n, n)), B=lr.matrix("B", (n, m), np.zeros((n, m))), E=lr.vector("E", n, np.zeros(n)))
        if lr.has("output"):
            kw["output"] = ExpressionMap(lr.raw("output"), (states, inputs), lr.at("output"), p)
        else:
            kw.update(C=lr.matrix("C", (p, n)), D=lr.matrix("D", (p, m), np.zeros((p, m))), c=lr.vector("c", p, np.zeros(p)))
        locs.append(Location(name, inv, **kw))
    edges = None
    if r.has("edges"):
        edges = []
        for k, er in enumerate(r.items("edges")):
            er.check_keys(_EDGE_KEYS)
            ends = [_location_index(er.raw(end), names, er.at(end)) for end in ("source", "target")]
            guard = polytope_from_dict(er.raw("guard"), [states], er.at("guard")) if er.has("guard") else None
            reset = None
            if er.has("reset"):
                rr = er.sub("reset")
                rr.check_keys(frozenset({"R", "r"}))
                reset = (rr.matrix("R", (n, n)), rr.vector("r", n))
            edges.append(Edge(ends[0], ends[1], guard, reset))
        edges = tuple(edges)
    return HybridAutomaton(tuple(locs), X, edges, U, states, inputs, outputs, name=r.string("name", "automaton"), p=p)


def _location_index(value: Any, names: list[str], field: str) -> int:
    if isinstance(value, str):
        if value not in names:
            raise ModelError(field, f"a location name among {names} or an index", repr(value))
        return names.index(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ModelError(field, f"a location index in 0..{len(names) - 1} or a name", repr(value))
    return value


# ---------------------------------------------------------------------------------- constant drift

def _drift_to_dict(s) -> dict[str, Any]:
    return {"class": "constant_drift", "name": "constant_drift", "states": list(s.state_names),
            "inputs": [], "outputs": ["y"], "modes": list(s.mode_names), "f": _matrix_list(s.f),
            "trigger": [int(v) for v in s.trigger], "alpha": _matrix_list(s.alpha), "h": [int(v) for v in s.h]}


def _drift_from_dict(r: _Reader):
    ConstantDriftSystem = _cls("ConstantDriftSystem")
    def ints(key):
        value = r.raw(key)
        if not isinstance(value, list) or not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
            raise ModelError(key, "a list of integers", repr(value))
        return np.array(value, dtype=np.int64)

    return ConstantDriftSystem(f=r.matrix("f", (None, None)), trigger=ints("trigger"), alpha=r.vector("alpha", None),
                               h=ints("h"), state_names=r.names("states"), mode_names=r.names("modes"))


# ---------------------------------------------------------------------------------- scalar nonlinear

def _function_to_dict(fn) -> dict[str, Any]:
    from .expressions import expression_text

    out = {"name": fn.name, "expr": expression_text(fn.sx(_Z), f"function {fn.name!r}.expr")}
    if fn.has_user_derivative:
        out["derivative"] = expression_text(fn.sx_deriv(_Z), f"function {fn.name!r}.derivative")
    return out


_Z = ca.SX.sym("z")


def _function_from_dict(r: _Reader, default_name: str):
    ScalarFunction = _cls("ScalarFunction")
    r.check_keys(_FUNCTION_KEYS)
    name = r.string("name", default_name)
    expr = r.raw("expr")
    deriv = r.raw("derivative", None)
    return ScalarFunction.from_text(name, expr, deriv, field=r.prefix.rstrip("."))


def _nonlinear_to_dict(s) -> dict[str, Any]:
    out: dict[str, Any] = {"class": "scalar_nonlinear", "name": s.name, "states": list(s.state_names),
                           "inputs": list(s.input_names), "outputs": list(s.output_names),
                           "box": polytope_to_dict(s.box), "A": _matrix_list(s.A), "B": _matrix_list(s.B),
                           "F": _matrix_list(s.F), "E": _matrix_list(s.E), "f": [_function_to_dict(fn) for fn in s.f],
                           "C": _matrix_list(s.C), "h": [_function_to_dict(fn) for fn in s.h]}
    if s.g is not None:
        out["g"] = _callable_texts(s.g, (s.output_names, s.input_names), s.n, "g")
    return out


def _nonlinear_from_dict(r: _Reader):
    ScalarNonlinearSystem = _cls("ScalarNonlinearSystem")
    states, inputs, outputs = r.names("states"), r.names("inputs"), r.names("outputs")
    n, k = len(states), len(inputs)
    if n == 0:
        raise ModelError("states", "the names of the states (at least one)", "an empty list")
    box = polytope_from_dict(r.raw("box"), [states], "box")
    f_items = r.items("f", [])
    f = tuple(_function_from_dict(fr, f"f{i + 1}") for i, fr in enumerate(f_items))
    if r.has("E"):
        E = r.matrix("E", (len(f), n))
    else:
        E = np.vstack([_argument_row(fr, states) for fr in f_items]) if f_items else np.zeros((0, n))
    C = r.matrix("C", (None, n))
    h = tuple(_function_from_dict(hr, f"h{j + 1}") for j, hr in enumerate(r.items("h"))) if r.has("h") else None
    g = ExpressionMap(r.raw("g"), (outputs or tuple(f"y{j + 1}" for j in range(C.shape[0])), inputs), "g", n) if r.has("g") else None
    return ScalarNonlinearSystem(
        box=box, C=C, h=h, A=r.matrix("A", (n, n), None), F=r.matrix("F", (n, len(f)), None) if f else None,
        E=E if f else None, f=f, B=r.matrix("B", (n, k), np.zeros((n, k))), g=g, state_names=states,
        input_names=inputs, output_names=outputs, name=r.string("name", "scalar_nonlinear"))


def _argument_row(fr: _Reader, states: tuple[str, ...]) -> np.ndarray:
    """``E_i`` from a function's ``"argument"`` (a linear expression of the states, e.g. ``"psi"``)."""
    if not fr.has("argument"):
        raise ModelError(fr.at("argument"), "the state combination the function acts on (e.g. 'psi'), "
                         "or a top-level 'E' matrix", "missing")
    symbols, variables = _symbols(states, fr.at("argument"))
    a, c = affine_coefficients(parse_expression(fr.raw("argument"), variables, fr.at("argument")), symbols, fr.at("argument"))
    if c != 0.0:
        raise ModelError(fr.at("argument"), "a linear combination of the states (no constant term)", f"constant {c}")
    return a

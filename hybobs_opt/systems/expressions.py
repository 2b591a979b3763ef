"""Expressions over named variables, as they are written in model files, and back.

A model file writes a nonlinear flow ``x3' = -cos(30 x2) + 0.4``, a scalar function ``V cos(z)``
or a guard ``theta - 0.03 <= 0`` as text.  :func:`parse_expression` turns such text into a CasADi
``SX`` expression of the named variables without evaluating any Python: the text is parsed by
:mod:`ast` and only the node types of a small arithmetic language are accepted (numbers, the
variable names, ``+ - * / **``, comparisons, ``and``/``or``/``not`` and the functions of
:data:`FUNCTIONS`); anything else (attribute access, subscripts, lambdas, unknown names, strings,
keyword arguments) is a :class:`~hybobs_opt.errors.ModelError` that names the entry and the
offending piece.

:func:`expression_text` is the inverse: it writes an ``SX`` scalar in the same language, with
every number printed by ``repr`` (so it reads back to the same double).  Writing, reading and
writing again gives the same text; that is what makes ``from_dict(to_dict(s))`` exact for systems
whose functions were given as Python callables of CasADi symbols (they are traced once, here).
"""

from __future__ import annotations

import ast
import math
import warnings
from collections.abc import Callable, Sequence

import casadi as ca
import numpy as np

from .._numbers import MAX_NUMBER_CHARS, is_decimal
from ..errors import ModelError

#: Longest expression text accepted (a guard against pathological inputs, not a modelling limit).
MAX_EXPRESSION_CHARS: int = 20_000
#: Deepest nesting accepted by the parser and the writer.
MAX_EXPRESSION_DEPTH: int = 200

#: Functions an expression may call, with their number of arguments.
FUNCTIONS: dict[str, tuple[Callable[..., ca.SX], int]] = {
    "sin": (ca.sin, 1), "cos": (ca.cos, 1), "tan": (ca.tan, 1),
    "asin": (ca.asin, 1), "acos": (ca.acos, 1), "atan": (ca.atan, 1), "atan2": (ca.atan2, 2),
    "sinh": (ca.sinh, 1), "cosh": (ca.cosh, 1), "tanh": (ca.tanh, 1),
    "asinh": (ca.asinh, 1), "acosh": (ca.acosh, 1), "atanh": (ca.atanh, 1),
    "exp": (ca.exp, 1), "expm1": (ca.expm1, 1), "log": (ca.log, 1), "log1p": (ca.log1p, 1),
    "sqrt": (ca.sqrt, 1), "abs": (ca.fabs, 1), "fabs": (ca.fabs, 1), "sign": (ca.sign, 1),
    "floor": (ca.floor, 1), "ceil": (ca.ceil, 1), "erf": (ca.erf, 1),
    "fmin": (ca.fmin, 2), "fmax": (ca.fmax, 2), "min": (ca.fmin, 2), "max": (ca.fmax, 2),
    "fmod": (ca.fmod, 2), "hypot": (ca.hypot, 2), "copysign": (ca.copysign, 2),
    "if_else": (lambda c, a, b: ca.if_else(c, a, b), 3),
}

#: Named constants (a variable of the same name takes precedence).
CONSTANTS: dict[str, float] = {"pi": math.pi, "e": math.e}

_BINARY = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.Div: lambda a, b: a / b, ast.Pow: lambda a, b: a ** b}
_COMPARE = {ast.Lt: lambda a, b: a < b, ast.LtE: lambda a, b: a <= b, ast.Gt: lambda a, b: a > b,
            ast.GtE: lambda a, b: a >= b, ast.Eq: lambda a, b: a == b, ast.NotEq: lambda a, b: a != b}


def parse_expression(text: str, variables: dict[str, ca.SX], field: str) -> ca.SX:
    """The ``SX`` scalar written by ``text`` over ``variables`` (name -> SX symbol).

    Parameters
    ----------
    text : str or float
        The expression, e.g. ``"-cos(30*x2) + 0.4"``; a finite number is a constant.
    variables : dict of str to casadi.SX
        The names the expression may use and their symbols.
    field : str
        Name of the entry in error messages.

    Returns
    -------
    casadi.SX
        The expression as a CasADi scalar over ``variables``.

    Raises
    ------
    ModelError
        ``text`` is not a string of the expression language, uses an unknown name or function,
        or is too long or too deep; ``field`` names the entry in the message.

    See Also
    --------
    expression_text : the inverse.

    Examples
    --------
    Model files write nonlinear functions as text; only numbers, arithmetic and the functions of
    ``FUNCTIONS`` are accepted (nothing is evaluated as Python):

    >>> import casadi as ca
    >>> from hybobs_opt.systems import parse_expression
    >>> x = ca.SX.sym("x")
    >>> expr = parse_expression("sin(x) + 2*x**2", {"x": x}, "f")
    >>> float(ca.substitute(expr, x, 0.0))
    0.0
    >>> parse_expression("__import__('os')", {"x": x}, "f")
    Traceback (most recent call last):
    ...
    hybobs_opt.errors.ModelError: f: expected an expression over the variables (x) ...
    """
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise ModelError(field, "an expression (a string such as '-cos(30*x2) + 0.4') or a number", type(text).__name__)
    if not isinstance(text, str):
        if not math.isfinite(float(text)):
            raise ModelError(field, "a finite number", repr(text))
        return ca.SX(float(text))
    if len(text) > MAX_EXPRESSION_CHARS:
        raise ModelError(field, f"an expression of at most {MAX_EXPRESSION_CHARS} characters", f"{len(text)} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ModelError(field, "an arithmetic expression", f"{text!r} ({exc.msg} at column {exc.offset})") from None
    except (RecursionError, MemoryError):  # Python's parser gives up on deep nesting below the length limit
        raise ModelError(field, f"an expression nested at most {MAX_EXPRESSION_DEPTH} deep", f"{text[:40]!r}... (deeper)") from None
    return _Builder(variables, field, text).build(tree.body, 0)


def _source(node: ast.AST) -> str:
    """The text of ``node`` for a message (short, and safe for deeply nested nodes)."""
    try:
        text = ast.unparse(node)
    except (RecursionError, MemoryError):
        return type(node).__name__
    return text if len(text) <= 80 else text[:77] + "..."


class _Builder:
    def __init__(self, variables: dict[str, ca.SX], field: str, text: str):
        self.variables, self.field, self.text = variables, field, text
        self.source = text.strip()  # what ast.parse read: the nodes' offsets point into it

    def fail(self, what: str) -> ModelError:
        names = ", ".join(sorted(self.variables)) or "none"
        return ModelError(self.field, f"an expression over the variables ({names}) with numbers, + - * / ** "
                          "and the functions of hybobs_opt.systems.expressions.FUNCTIONS", f"{what} in {self.text!r}")

    def build(self, node: ast.AST, depth: int) -> ca.SX:
        if depth > MAX_EXPRESSION_DEPTH:
            raise self.fail(f"nesting deeper than {MAX_EXPRESSION_DEPTH}")
        d = depth + 1
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise self.fail(f"the literal {node.value!r}")
            written = ast.get_source_segment(self.source, node) or ""
            if not is_decimal(written):  # 8_0, 0x10, 1j, non-ASCII digits, 400-digit integers
                raise self.fail(f"the number {written[:40]!r} (ASCII decimal digits, at most {MAX_NUMBER_CHARS} "
                                "characters)")
            value = float(written)
            if not math.isfinite(value):
                raise self.fail(f"the non-finite number {written!r}")
            return ca.SX(value)
        if isinstance(node, ast.Name):
            if node.id in self.variables:
                return self.variables[node.id]
            if node.id in CONSTANTS:
                return ca.SX(CONSTANTS[node.id])
            raise self.fail(f"the unknown name {node.id!r}")
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](self.build(node.left, d), self.build(node.right, d))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd, ast.Not)):
            v = self.build(node.operand, d)
            return -v if isinstance(node.op, ast.USub) else (ca.logic_not(v) if isinstance(node.op, ast.Not) else v)
        if isinstance(node, ast.Compare):
            left, out = self.build(node.left, d), None
            for op, comp in zip(node.ops, node.comparators):
                if type(op) not in _COMPARE:
                    raise self.fail(f"the comparison {type(op).__name__}")
                right = self.build(comp, d)
                term = _COMPARE[type(op)](left, right)
                out = term if out is None else ca.logic_and(out, term)
                left = right
            return out
        if isinstance(node, ast.BoolOp):
            values = [self.build(v, d) for v in node.values]
            combine = ca.logic_and if isinstance(node.op, ast.And) else ca.logic_or
            out = values[0]
            for v in values[1:]:
                out = combine(out, v)
            return out
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                what = node.func.id if isinstance(node.func, ast.Name) else _source(node.func)
                raise self.fail(f"a call of {what!r} (known: {', '.join(sorted(FUNCTIONS))})")
            fn, arity = FUNCTIONS[node.func.id]
            if node.keywords or any(isinstance(a, ast.Starred) for a in node.args) or len(node.args) != arity:
                raise self.fail(f"{node.func.id}() with other than {arity} positional argument(s)")
            return fn(*(self.build(a, d) for a in node.args))
        raise self.fail(f"the construct {_source(node)!r} ({type(node).__name__})")


# ---------------------------------------------------------------------------------- writing

_INFIX = {ca.OP_ADD: "+", ca.OP_SUB: "-", ca.OP_MUL: "*", ca.OP_DIV: "/", ca.OP_LT: "<", ca.OP_LE: "<=",
          ca.OP_EQ: "==", ca.OP_NE: "!="}
_CALLS = {ca.OP_SIN: "sin", ca.OP_COS: "cos", ca.OP_TAN: "tan", ca.OP_ASIN: "asin", ca.OP_ACOS: "acos",
          ca.OP_ATAN: "atan", ca.OP_ATAN2: "atan2", ca.OP_SINH: "sinh", ca.OP_COSH: "cosh", ca.OP_TANH: "tanh",
          ca.OP_ASINH: "asinh", ca.OP_ACOSH: "acosh", ca.OP_ATANH: "atanh", ca.OP_EXP: "exp", ca.OP_EXPM1: "expm1",
          ca.OP_LOG: "log", ca.OP_LOG1P: "log1p", ca.OP_SQRT: "sqrt", ca.OP_FABS: "fabs", ca.OP_SIGN: "sign",
          ca.OP_FLOOR: "floor", ca.OP_CEIL: "ceil", ca.OP_ERF: "erf", ca.OP_FMIN: "fmin", ca.OP_FMAX: "fmax",
          ca.OP_FMOD: "fmod", ca.OP_HYPOT: "hypot", ca.OP_COPYSIGN: "copysign"}


#: How each operation that is not a plain function call is written (CasADi's own rewrites
#: ``2*x -> twice(x)``, ``x**2 -> sq(x)`` read back to the same operations).
_TEMPLATES = {
    **{op: "({0} " + sym + " {1})" for op, sym in _INFIX.items()},
    ca.OP_NEG: "(-{0})", ca.OP_TWICE: "(2.0 * {0})", ca.OP_SQ: "({0} ** 2.0)", ca.OP_POW: "({0} ** {1})",
    ca.OP_CONSTPOW: "({0} ** {1})", ca.OP_INV: "(1.0 / {0})", ca.OP_NOT: "(not {0})", ca.OP_AND: "({0} and {1})",
    ca.OP_OR: "({0} or {1})", ca.OP_IF_ELSE_ZERO: "if_else({0}, {1}, 0.0)",
}


def expression_text(expr: ca.SX, field: str) -> str:
    """``expr`` (an ``SX`` scalar) written in the language of :func:`parse_expression`.

    Parameters
    ----------
    expr : casadi.SX
        A scalar expression.
    field : str
        Name of the entry in error messages.

    Returns
    -------
    str
        Text that :func:`parse_expression` reads back into the same expression.

    Raises
    ------
    ModelError
        ``expr`` is not a scalar or uses an operation the language cannot write.

    See Also
    --------
    parse_expression : the inverse.

    Examples
    --------
    >>> import casadi as ca
    >>> from hybobs_opt.systems import expression_text, parse_expression
    >>> x = ca.SX.sym("x")
    >>> expression_text(parse_expression("sin(x) + 2*x**2", {"x": x}, "f"), "f")
    '(sin(x) + (2.0 * (x ** 2.0)))'
    """
    expr = ca.SX(expr)
    if expr.shape != (1, 1):
        raise ModelError(field, "a scalar expression", f"shape {expr.shape}")
    budget = [MAX_EXPRESSION_CHARS]
    return _write(expr, field, 0, budget)


def _spend(text: str, budget: list[int], field: str, counted: int = 0) -> str:
    """Charge the new characters of ``text`` to ``budget``; refuse text longer than the reader accepts.

    The text is a tree: a subexpression the CasADi graph shares is written each time it is used,
    so a flow traced from Python (``y = 0.5*y + sin(y)`` repeated) can grow exponentially.
    """
    budget[0] -= len(text) - counted
    if budget[0] < 0:
        raise ModelError(field, f"an expression that writes in at most {MAX_EXPRESSION_CHARS} characters (shared "
                         "subexpressions are written out each time they are used)", "a longer one: give the function "
                         "as text in the model file, or simplify it")
    return text


def _if_else_parts(e: ca.SX):
    """``(c, a, b)`` when ``e`` is ``(c ? a : 0) + (!c ? b : 0)`` (how CasADi stores ``if_else``), else ``None``."""
    if e.op() != ca.OP_ADD:
        return None
    left, right = e.dep(0), e.dep(1)
    if left.is_constant() or right.is_constant() or left.op() != ca.OP_IF_ELSE_ZERO or right.op() != ca.OP_IF_ELSE_ZERO:
        return None
    c, nc = left.dep(0), right.dep(0)
    if nc.is_constant() or nc.is_symbolic() or nc.op() != ca.OP_NOT or not ca.is_equal(nc.dep(0), c, 1):
        return None
    return c, left.dep(1), right.dep(1)


def _number(value: float, field: str) -> str:
    if not math.isfinite(value):
        raise ModelError(field, "finite constants", repr(value))
    text = repr(float(value))
    return f"({text})" if value < 0 or text.startswith("-") else text


def _write(e: ca.SX, field: str, depth: int, budget: list[int]) -> str:
    if depth > MAX_EXPRESSION_DEPTH:
        raise ModelError(field, f"an expression nested at most {MAX_EXPRESSION_DEPTH} deep", "a deeper one")
    if e.is_constant():
        return _spend(_number(float(e), field), budget, field)
    if e.is_symbolic():
        return _spend(e.name(), budget, field)
    op, d = e.op(), depth + 1
    branches = _if_else_parts(e)
    if branches is not None:  # if_else(c, a, b) is stored as (c ? a : 0) + (!c ? b : 0): write c once
        c, a, b = (_write(part, field, d, budget) for part in branches)
        return _spend(f"if_else({c}, {a}, {b})", budget, field, len(c) + len(a) + len(b))
    args = [_write(e.dep(i), field, d, budget) for i in range(e.n_dep())]
    if op in _TEMPLATES:
        return _spend(_TEMPLATES[op].format(*args), budget, field, sum(map(len, args)))
    if op in _CALLS:
        return _spend(f"{_CALLS[op]}({', '.join(args)})", budget, field, sum(map(len, args)))
    raise ModelError(field, "an expression built from arithmetic and the functions of hybobs_opt.systems.expressions",
                     f"the CasADi operation {op} in {str(e)[:80]}")


# ---------------------------------------------------------------------------------- vectors

def parse_vector(texts, variables: dict[str, ca.SX], field: str, size: int) -> ca.SX:
    """A column of ``size`` expressions (``texts`` a list of strings or numbers)."""
    if isinstance(texts, (str, bytes)) or not isinstance(texts, Sequence):
        raise ModelError(field, f"a list of {size} expressions", type(texts).__name__)
    if len(texts) != size:
        raise ModelError(field, f"{size} expressions", f"{len(texts)}")
    return ca.vertcat(*[parse_expression(t, variables, f"{field}[{i}]") for i, t in enumerate(texts)]) if size else ca.SX.zeros(0, 1)


def trace_callable(fn: Callable, arguments: Sequence[ca.SX], size: int, field: str) -> ca.SX:
    """Call a Python function on CasADi symbols and return the ``(size, 1)`` SX it builds.

    Used to write a flow given as a Python callable (``flow(x, u)`` with numpy functions) to a
    model file.  Raises ``ModelError`` when the callable cannot run on symbols (it branches on
    values, calls a library without a CasADi equivalent, ...).
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # casadi's notice about numpy functions on SX
            raw = fn(*arguments)
            if isinstance(raw, np.ndarray):
                raw = ca.vertcat(*[ca.SX(v) for v in raw.ravel().tolist()]) if raw.size else ca.SX.zeros(0, 1)
            elif isinstance(raw, (list, tuple)):
                raw = ca.vertcat(*[ca.SX(v) for v in raw]) if raw else ca.SX.zeros(0, 1)
            out = ca.SX(raw)
    except Exception as exc:  # a callable may raise anything on symbolic arguments
        raise ModelError(field, "a callable that runs on CasADi symbols (so it can be written as expressions), "
                         "or expressions given as strings", f"{type(exc).__name__}: {exc}") from None
    out = ca.reshape(out, -1, 1)
    if out.shape[0] != size:
        raise ModelError(field, f"{size} values", f"{out.shape[0]}")
    return out


def vector_texts(expr: ca.SX, field: str) -> list[str]:
    """The entries of an ``SX`` column, written by :func:`expression_text`."""
    return [expression_text(expr[i], f"{field}[{i}]") for i in range(expr.shape[0])]


def affine_coefficients(expr: ca.SX, symbols: ca.SX, field: str) -> tuple[np.ndarray, float]:
    """``(a, c)`` with ``expr = a . symbols + c`` exactly; ``ModelError`` when ``expr`` is not affine."""
    if not _is_affine(expr, symbols):
        raise ModelError(field, "a linear inequality (affine in the variables: sums, and products and quotients "
                         "by constants)", f"the expression {str(expr)[:80]}")
    jac = ca.jacobian(expr, symbols)
    fn = ca.Function("affine", [symbols], [jac, expr])
    a, c = fn(np.zeros(symbols.shape[0]))
    return np.asarray(a, dtype=float).ravel(), float(c)


def _is_affine(e: ca.SX, symbols: ca.SX) -> bool:
    """Structural test: ``e`` is built from the symbols by ``+ -``, and ``* /`` by constants.

    (A Jacobian free of the variables is not enough: ``floor(x)``, ``x > 0`` and ``sign(x)`` have
    derivative 0 and would read as constants.)
    """
    if not ca.depends_on(e, symbols) or e.is_symbolic():
        return True
    op = e.op()
    if op in (ca.OP_ADD, ca.OP_SUB):
        return _is_affine(e.dep(0), symbols) and _is_affine(e.dep(1), symbols)
    if op in (ca.OP_NEG, ca.OP_TWICE):
        return _is_affine(e.dep(0), symbols)
    if op == ca.OP_MUL:
        a, b = e.dep(0), e.dep(1)
        return (not ca.depends_on(a, symbols) and _is_affine(b, symbols)) or (not ca.depends_on(b, symbols) and _is_affine(a, symbols))
    if op == ca.OP_DIV:
        return not ca.depends_on(e.dep(1), symbols) and _is_affine(e.dep(0), symbols)
    return False

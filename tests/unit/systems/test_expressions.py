"""The expression language of model files (hybobs_opt.systems.expressions), tested from outside.

Expected values come from hand-written numpy formulas (never from the module under test);
the writer is checked by a round trip ``text(parse(text(parse(s)))) == text(parse(s))`` with
bit-identical values, on hand-picked and on randomly generated expression trees; every refusal
must be a ``ModelError`` whose ``field`` is the entry passed in.
"""

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from hybobs_opt.errors import ModelError
from hybobs_opt.systems.expressions import MAX_EXPRESSION_CHARS, expression_text, parse_expression

NAMES = ("x", "y", "z")
SYMBOLS = {name: ca.SX.sym(name) for name in NAMES}
FIELD = "locations[1].flow[2]"
RNG_POINTS = np.random.default_rng(20240611).uniform(-2.0, 2.0, size=(3, 400))


def values(expr: ca.SX, points: np.ndarray = RNG_POINTS) -> np.ndarray:
    """``expr`` evaluated on the columns of ``points`` (rows: x, y, z), by CasADi."""
    fn = ca.Function("f", [SYMBOLS[n] for n in NAMES], [expr])
    return np.asarray(fn(*(points[i][None, :] for i in range(3))), dtype=float).ravel()


def parse(text, field: str = FIELD) -> ca.SX:
    return parse_expression(text, SYMBOLS, field)


def assert_bitwise_equal(a: np.ndarray, b: np.ndarray) -> None:
    """Same doubles bit for bit (NaN matches NaN; -0.0 does not match 0.0)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    assert np.array_equal(nan_a, nan_b)
    assert np.array_equal(a[~nan_a].view(np.int64), b[~nan_b].view(np.int64))


# ---------------------------------------------------------------------------------- values

# (text, the same formula in numpy over x, y, z), points drawn in [-2, 2]^3.
HAND = [
    ("sin(x) + cos(y)", lambda x, y, z: np.sin(x) + np.cos(y)),
    ("x**2 - 3*x*y + 2", lambda x, y, z: x**2 - 3 * x * y + 2),
    ("atan2(y, x)", lambda x, y, z: np.arctan2(y, x)),
    ("2*atan2(-y, x - 3)", lambda x, y, z: 2 * np.arctan2(-y, x - 3)),
    ("if_else(x > y, x - y, y**2)", lambda x, y, z: np.where(x > y, x - y, y**2)),
    ("(x <= y) + 2*(x >= 0.5) + 4*(z < 0) + 8*(y > z) + 16*(x != y) + 32*(x == x)",
     lambda x, y, z: (x <= y) + 2.0 * (x >= 0.5) + 4.0 * (z < 0) + 8.0 * (y > z) + 16.0 * (x != y) + 32.0),
    ("-x**2", lambda x, y, z: -(x**2)),  # Python precedence: - (x ** 2)
    ("2**-x", lambda x, y, z: 2.0 ** (-x)),
    ("abs(x)**2**0.5", lambda x, y, z: np.abs(x) ** (2**0.5)),  # right-associative: |x| ** (2 ** 0.5)
    ("pi*x + e", lambda x, y, z: math.pi * x + math.e),
    ("exp(-x**2/2)/sqrt(2*pi)", lambda x, y, z: np.exp(-(x**2) / 2) / np.sqrt(2 * np.pi)),
    ("tanh(x)*sinh(y)/cosh(z)", lambda x, y, z: np.tanh(x) * np.sinh(y) / np.cosh(z)),
    ("log(1 + x**2) + log1p(y*y) - expm1(z)", lambda x, y, z: np.log(1 + x**2) + np.log1p(y * y) - np.expm1(z)),
    ("hypot(x, y) + fmin(x, z) + max(y, 0) - min(z, -1) + fmax(x, y)",
     lambda x, y, z: np.hypot(x, y) + np.fmin(x, z) + np.maximum(y, 0) - np.minimum(z, -1) + np.fmax(x, y)),
    ("abs(x)*sign(y) + fabs(z)", lambda x, y, z: np.abs(x) * np.sign(y) + np.abs(z)),
    ("floor(3*x) - ceil(2*y)", lambda x, y, z: np.floor(3 * x) - np.ceil(2 * y)),
    ("fmod(x, 0.7) + copysign(1.5, y)*z", lambda x, y, z: np.fmod(x, 0.7) + np.copysign(1.5, y) * z),
    ("x/(y + 3) - 1/(z - 3)", lambda x, y, z: x / (y + 3) - 1 / (z - 3)),
    ("(x > 0) and (y < 0) or not (z < -0.5)",
     lambda x, y, z: np.logical_or(np.logical_and(x > 0, y < 0), np.logical_not(z < -0.5)).astype(float)),
    ("x < y < 0.3", lambda x, y, z: ((x < y) & (y < 0.3)).astype(float)),
    ("asin(x/3) + acos(y/3) + atan(x*y)", lambda x, y, z: np.arcsin(x / 3) + np.arccos(y / 3) + np.arctan(x * y)),
    ("asinh(x) + acosh(2 + y*y) + atanh(z/3)", lambda x, y, z: np.arcsinh(x) + np.arccosh(2 + y * y) + np.arctanh(z / 3)),
    ("erf(x) + tan(y/2)", lambda x, y, z: np.array([math.erf(v) for v in x]) + np.tan(y / 2)),
    ("abs(x)**y", lambda x, y, z: np.abs(x) ** y),
    ("+x - (-y) - - z", lambda x, y, z: x + y + z),
    ("1e-3*x + 2.5E2 - 7", lambda x, y, z: 1e-3 * x + 250.0 - 7),
    ("sin(x)**2 + cos(x)**2", lambda x, y, z: np.ones_like(x)),
    ("if_else(x*y > 0, if_else(z > 0, 1, 2), 3)",
     lambda x, y, z: np.where(x * y > 0, np.where(z > 0, 1.0, 2.0), 3.0)),
    ("  x *   y  ", lambda x, y, z: x * y),  # surrounding blanks are allowed
]


@pytest.mark.parametrize("text, reference", HAND, ids=[t for t, _ in HAND])
def test_parse_evaluates_like_numpy(text, reference):
    x, y, z = RNG_POINTS
    with np.errstate(all="ignore"):
        expected = np.asarray(reference(x, y, z), dtype=float) * np.ones_like(x)
    np.testing.assert_allclose(values(parse(text)), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("text", [t for t, _ in HAND])
def test_written_text_reads_back_to_the_same_values_and_text(text):
    first = parse(text)
    written = expression_text(first, FIELD)
    again = parse(written)
    assert expression_text(again, FIELD) == written
    with np.errstate(all="ignore"):
        assert_bitwise_equal(values(again), values(first))


def test_numbers_as_well_as_text():
    assert float(parse(3)) == 3.0
    assert float(parse(-2.5)) == -2.5
    assert float(parse("-2.5")) == -2.5
    assert float(parse("pi")) == math.pi and float(parse("e")) == math.e


def test_a_variable_shadows_a_constant_of_the_same_name():
    pi, x = ca.SX.sym("pi"), ca.SX.sym("x")
    expr = parse_expression("pi + x", {"pi": pi, "x": x}, FIELD)
    fn = ca.Function("f", [pi, x], [expr])
    assert float(fn(10.0, 1.0)) == 11.0


def test_written_numbers_are_exact():
    """``repr`` of every constant: awkward doubles read back to the same bits."""
    for v in (0.1, 1 / 3, -2.0 ** -1074, 1.7976931348623157e308, 2.0 ** -1022, 123456789.12345678, -1e-300):
        written = expression_text(parse(f"x + {v!r}"), FIELD)
        assert_bitwise_equal(values(parse(written)), RNG_POINTS[0] + v)


# ---------------------------------------------------------------------------------- random trees

_UNARY = ("sin", "cos", "tan", "atan", "tanh", "sinh", "exp", "sqrt", "abs", "floor", "ceil", "sign", "erf",
          "asinh", "log", "log1p", "expm1", "asin", "acos", "atanh", "acosh", "cosh")
_BINARY_CALLS = ("atan2", "fmin", "fmax", "hypot", "copysign", "fmod", "min", "max")
_INFIX_OPS = ("+", "-", "*", "/", "**", "<", "<=", ">", ">=", "==", "!=", "and", "or")


def _number_text(v: float) -> str:
    return f"({v!r})" if v < 0 or math.copysign(1.0, v) < 0 else repr(v)


_leaves = st.one_of(
    st.sampled_from(NAMES),
    st.sampled_from(("pi", "e", "0", "1", "2", "0.5", "-1", "1e-3", "3.75")),
    st.floats(min_value=-1e3, max_value=1e3, allow_nan=False).map(_number_text),
    st.integers(min_value=-20, max_value=20).map(str),
)


def _extend(children):
    return st.one_of(
        st.tuples(st.sampled_from(("-", "+", "not ")), children).map(lambda t: f"({t[0]}{t[1]})"),
        st.tuples(children, st.sampled_from(_INFIX_OPS), children).map(lambda t: f"({t[0]} {t[1]} {t[2]})"),
        st.tuples(st.sampled_from(_UNARY), children).map(lambda t: f"{t[0]}({t[1]})"),
        st.tuples(st.sampled_from(_BINARY_CALLS), children, children).map(lambda t: f"{t[0]}({t[1]}, {t[2]})"),
        st.tuples(children, children, children).map(lambda t: f"if_else({t[0]}, {t[1]}, {t[2]})"),
    )


random_expressions = st.recursive(_leaves, _extend, max_leaves=12)


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_expressions)
def test_random_trees_write_read_write_is_a_fixed_point(text):
    first = parse(text)
    try:
        written = expression_text(first, FIELD)
    except ModelError as exc:
        # The only thing the writer may refuse here: a constant that folded to inf/NaN (e.g. 1/0).
        assert exc.field == FIELD and "finite" in exc.expected
        assume(False)
    again = parse(written)
    assert expression_text(again, FIELD) == written
    with np.errstate(all="ignore"):
        assert_bitwise_equal(values(again), values(first))


def _smooth(children):
    """Trees whose values stay moderate, each with its numpy twin: (text, fn(x, y, z))."""
    return st.one_of(
        children.map(lambda c: (f"(-{c[0]})", lambda x, y, z, f=c[1]: -f(x, y, z))),
        st.tuples(children, st.sampled_from("+-*"), children).map(
            lambda t: (f"({t[0][0]} {t[1]} {t[2][0]})",
                       lambda x, y, z, a=t[0][1], b=t[2][1], op=t[1]:
                       a(x, y, z) + b(x, y, z) if op == "+" else a(x, y, z) - b(x, y, z) if op == "-"
                       else a(x, y, z) * b(x, y, z))),
        st.tuples(st.sampled_from(("sin", "cos", "atan", "tanh")), children).map(
            lambda t: (f"{t[0]}({t[1][0]})",
                       lambda x, y, z, f=t[1][1], g={"sin": np.sin, "cos": np.cos, "atan": np.arctan,
                                                    "tanh": np.tanh}[t[0]]: g(f(x, y, z)))),
        st.tuples(children, children).map(
            lambda t: (f"({t[0][0]} / (1 + {t[1][0]}**2))",
                       lambda x, y, z, a=t[0][1], b=t[1][1]: a(x, y, z) / (1 + b(x, y, z) ** 2))),
        st.tuples(children, children, children).map(
            lambda t: (f"if_else({t[0][0]} > 0.25, {t[1][0]}, {t[2][0]})",
                       lambda x, y, z, c=t[0][1], a=t[1][1], b=t[2][1]:
                       np.where(c(x, y, z) > 0.25, a(x, y, z), b(x, y, z)))),
    )


_smooth_leaves = st.one_of(
    st.sampled_from([(n, lambda x, y, z, i=i: (x, y, z)[i]) for i, n in enumerate(NAMES)]),
    st.floats(min_value=-3, max_value=3, allow_nan=False).map(lambda v: (_number_text(v), lambda x, y, z, v=v: v + 0 * x)),
)


@settings(max_examples=150, deadline=None)
@given(st.recursive(_smooth_leaves, _smooth, max_leaves=10))
def test_random_smooth_trees_evaluate_like_numpy(pair):
    text, reference = pair
    x, y, z = RNG_POINTS
    expected = reference(x, y, z) * np.ones_like(x)
    got = values(parse(text))
    scale = 1.0 + np.max(np.abs(expected))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * scale)


# ---------------------------------------------------------------------------------- refusals

REFUSED = [
    ("__import__('os')", "__import__"),
    ("__import__('os').system('true')", "system"),
    ("x.real", "x.real"),
    ("sin.__call__(x)", "__call__"),
    ("x[0]", "x[0]"),
    ("(lambda: 1)()", "lambda"),
    ("lambda x: x", "lambda"),
    ("foo + x", "foo"),
    ("bar(x)", "bar"),
    ("open('f')", "open"),
    ("eval('1')", "eval"),
    ("sin(x=1)", "sin()"),
    ("sin(*[x])", "sin()"),
    ("atan2(x)", "atan2()"),
    ("sin(x, y)", "sin()"),
    ("'abc'", "'abc'"),
    ("x + 'abc'", "'abc'"),
    ("b'x'", "b'x'"),
    ("True", "True"),
    ("x + False", "False"),
    ("None", "None"),
    ("inf", "inf"),
    ("nan", "nan"),
    ("1e400", "non-finite"),
    ("1j", "1j"),
    ("x if y else z", "IfExp"),
    ("[x, y]", "List"),
    ("(x, y)", "Tuple"),
    ("{x: y}", "Dict"),
    ("x // y", "//"),
    ("x % y", "%"),
    ("x @ y", "@"),
    ("x << 1", "<<"),
    ("~x", "~x"),
    ("x is y", "Is"),
    ("x in y", "In"),
    ("[v for v in x]", "ListComp"),
    ("(y := 1)", "NamedExpr"),
    ("f'{x}'", "JoinedStr"),
    ("x +", "column"),
    ("", "column"),
    ("x = 1", "column"),
    ("import os", "column"),
    ("x" * (MAX_EXPRESSION_CHARS + 1), "characters"),
    ("-" * 201 + "x", "deeper"),
    ("sin(-" * 110 + "x" + ")" * 110, "deeper"),
]


@pytest.mark.parametrize("text, mention", REFUSED, ids=[t[:40] for t, _ in REFUSED])
def test_refused_text_names_the_field(text, mention):
    with pytest.raises(ModelError) as info:
        parse(text)
    assert info.value.field == FIELD
    assert str(info.value).startswith(FIELD + ": expected ")
    assert mention in str(info.value)


@pytest.mark.parametrize("value", [True, False, None, [1.0], {"x": 1}, float("inf"), float("-inf"), float("nan"),
                                   ca.SX.sym("x")], ids=repr)
def test_refused_values_name_the_field(value):
    with pytest.raises(ModelError) as info:
        parse(value)
    assert info.value.field == FIELD


def test_length_limit_is_exact():
    text = "x" * MAX_EXPRESSION_CHARS
    with pytest.raises(ModelError) as info:  # the longest text is accepted by length, refused as an unknown name
        parse(text)
    assert "characters" not in (info.value.got or "")


def test_writer_refuses_non_scalars_and_unwritable_operations():
    with pytest.raises(ModelError) as info:
        expression_text(ca.vertcat(SYMBOLS["x"], SYMBOLS["y"]), "g")
    assert info.value.field == "g"
    with pytest.raises(ModelError) as info:
        expression_text(ca.SX(float("nan")), "g[0]")
    assert info.value.field == "g[0]"


@pytest.mark.parametrize("text", ["-" * 5000 + "x", "x+" * 4000 + "x", "x**" * 5000 + "x", "x" + ".a" * 2000,
                                  "x" + "[0]" * 2000], ids=["neg", "plus", "pow", "attr", "subscript"])
def test_deeply_nested_text_is_a_model_error(text):
    assert len(text) <= MAX_EXPRESSION_CHARS
    with pytest.raises(ModelError) as info:
        parse(text)
    assert info.value.field == FIELD


def test_written_text_of_nested_conditions_reads_back():
    text = "x"
    for _ in range(9):
        text = f"if_else({text} > 0, x, 1)"
    assert len(text) < 200
    written = expression_text(parse(text), FIELD)
    again = parse(written)
    assert expression_text(again, FIELD) == written

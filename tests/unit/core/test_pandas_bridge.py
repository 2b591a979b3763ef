"""pandas in and out: ``read_log`` of a DataFrame, ``to_pandas`` of traces, logs and window results.

The DataFrames of the shipped logs are built from the CSV text with the ``csv`` module (not
with ``read_log``, and not with ``pandas.read_csv``, which renames a repeated column), so that
``read_log(df)`` is compared with ``read_log(path)`` on independent input.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

pd = pytest.importorskip("pandas", reason="pandas (the interop extra) is not installed")

from hybobs_opt import ModelError, ObserverTrace, Trace, get_example, load_model, read_log
from hybobs_opt.mhe.result import WindowResult
from hybobs_opt.sim import simulate_pwa

ROOT = Path(__file__).resolve().parents[3]
INPUTS = ROOT / "tests" / "app" / "cli_json_golden" / "inputs"


def _system(name: str):
    if name == "powertrain3":
        return get_example("powertrain3").build()
    return load_model(ROOT / "examples" / "models" / name)


SHIPPED_LOGS = [("rotation_sine.csv", "bemporad_morari_rotation.json"),
                ("powertrain3_window.csv", "powertrain3"),
                ("flexible_joint_robot.csv", "flexible_joint_robot.toml")]


def _frame_of_csv(path: Path) -> pd.DataFrame:
    with path.open(newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.reader(fh) if r]
    return pd.DataFrame([[float(c) for c in r] for r in rows[1:]], columns=[h.strip() for h in rows[0]])


def _assert_same_log(a, b):
    for key in ("U", "Y", "t", "X", "Q"):
        va, vb = getattr(a, key), getattr(b, key)
        assert (va is None) == (vb is None), key
        if va is not None:
            np.testing.assert_array_equal(va, vb, err_msg=key)


@pytest.mark.parametrize("log_name, model", SHIPPED_LOGS)
def test_read_log_of_a_dataframe_equals_read_log_of_the_file(log_name, model):
    system = _system(model)
    path = INPUTS / log_name
    df = _frame_of_csv(path)
    from_file, from_frame = read_log(path, system), read_log(df, system)
    _assert_same_log(from_frame, from_file)
    assert from_frame.path == "DataFrame"
    assert from_file.n_samples == len(df) > 1
    # and the log's own frame reads back to the same arrays
    _assert_same_log(read_log(from_file.to_pandas(system), system), from_file)


def test_the_powertrain_log_has_a_repeated_column_and_states():
    df = _frame_of_csv(INPUTS / "powertrain3_window.csv")
    assert list(df.columns).count("omega_m") == 2
    log = read_log(df, _system("powertrain3"))
    assert log.X is not None and log.Q is not None
    np.testing.assert_array_equal(log.Y[:, 0], df.iloc[:, 2].to_numpy())


def _rotation_trace() -> tuple[object, Trace]:
    system = _system("bemporad_morari_rotation.json")
    U = 0.5 * np.sin(np.arange(12))[:, None]
    return system, simulate_pwa(system, np.array([3.0, -2.0]), U)


def test_trace_to_pandas_columns_and_values():
    system, trace = _rotation_trace()
    df = trace.to_pandas()
    assert list(df.columns) == ["t", "x1", "x2", "q", "u", "y"]
    assert len(df) == trace.n_samples == 12
    np.testing.assert_array_equal(df["t"].to_numpy(), np.arange(12.0))
    np.testing.assert_array_equal(df[["x1", "x2"]].to_numpy(), trace.x)
    np.testing.assert_array_equal(df["q"].to_numpy(), trace.q)
    assert df["q"].dtype.kind == "i"
    np.testing.assert_array_equal(df["u"].to_numpy(), 0.5 * np.sin(np.arange(12)))
    np.testing.assert_array_equal(df["y"].to_numpy(), trace.y[:, 0])
    # the frame is a log of the system
    log = read_log(df, system)
    np.testing.assert_array_equal(log.X, trace.x)
    np.testing.assert_array_equal(log.Q, trace.q)
    np.testing.assert_array_equal(log.Y, trace.y)


def test_trace_to_pandas_merges_an_output_that_is_a_state():
    t = Trace([0.0, 1.0], [[1.0, 2.0], [3.0, 4.0]], [0, 0], [[0.0], [0.0]], [[2.0], [4.0]], ("a", "b"), ("u",), ("b",))
    assert list(t.to_pandas().columns) == ["t", "a", "b", "q", "u"]
    bad = Trace([0.0, 1.0], [[1.0, 2.0], [3.0, 4.0]], [0, 0], [[0.0], [0.0]], [[2.0], [5.0]], ("a", "b"), ("u",), ("b",))
    with pytest.raises(ModelError) as err:
        bad.to_pandas()
    assert err.value.field == "Trace column 'b'"


def test_observer_trace_to_pandas_with_radii():
    run = ObserverTrace(np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]), np.array([-1, 0, 1]),
                        np.array(["warming_up", "observable", "fallback"], dtype=object), np.array([0.1, 0.2, 0.3]),
                        ("p", "v"), "obs", ({}, {"radius": [0.5, 0.25]}, {}))
    df = run.to_pandas(t=[0.0, 0.5, 1.0])
    assert list(df.columns) == ["t", "p", "v", "mode", "flag", "seconds", "radius_p", "radius_v"]
    assert df["flag"].tolist() == ["warming_up", "observable", "fallback"]
    assert df["mode"].tolist() == [-1, 0, 1]
    np.testing.assert_array_equal(df["v"].to_numpy(), [2.0, 4.0, 6.0])
    np.testing.assert_array_equal(df["radius_p"].to_numpy(), [np.nan, 0.5, np.nan])
    np.testing.assert_array_equal(df["seconds"].to_numpy(), [0.1, 0.2, 0.3])
    assert list(run.to_pandas().columns)[:2] == ["p", "v"]
    with pytest.raises(ModelError) as err:
        run.to_pandas(t=[0.0, 1.0])
    assert err.value.field == "t"


def test_window_result_to_pandas():
    res = WindowResult("optimal", states=np.array([[1.0, 0.0], [0.5, 1.0], [0.25, 2.0]]), modes=np.array([0, 0, 1]),
                       w=np.array([[0.1, 0.2], [0.3, 0.4]]))
    df = res.to_pandas(("p", "v"))
    assert list(df.columns) == ["k", "p", "v", "mode", "w_p", "w_v"]
    assert df["k"].tolist() == [0, 1, 2]
    np.testing.assert_array_equal(df["w_v"].to_numpy(), [0.2, 0.4, np.nan])
    assert list(res.to_pandas().columns)[1:3] == ["x1", "x2"]
    with pytest.raises(ModelError) as err:
        WindowResult("not certified", reason="no point").to_pandas()
    assert err.value.field == "states" and "no point" in err.value.got


# ---------------------------------------------------------------- the same validation as a file
class _Sys:
    input_names, output_names, state_names = ("u",), ("y",), ("x1", "x2")


def _both(tmp_path, df: pd.DataFrame):
    """The ModelErrors of the file and of the DataFrame with the same content."""
    path = tmp_path / "log.csv"
    df.to_csv(path, index=False)
    errs = []
    for source in (path, df):
        with pytest.raises(ModelError) as err:
            read_log(source, _Sys)
        errs.append(err.value)
    return errs


def test_missing_and_unknown_columns_give_the_same_errors(tmp_path):
    for df in (pd.DataFrame({"u": [1.0]}), pd.DataFrame({"u": [1.0], "y": [1.0], "z": [0.0]}),
               pd.DataFrame({"u": [1.0], "y": [1.0], "x1": [0.0]})):
        from_file, from_frame = _both(tmp_path, df)
        assert from_frame.field == "DataFrame header"
        assert (from_frame.expected, from_frame.got) == (from_file.expected, from_file.got)


def test_times_must_increase_like_in_a_file(tmp_path):
    from_file, from_frame = _both(tmp_path, pd.DataFrame({"t": [0.0, 1.0, 1.0], "u": [0.0] * 3, "y": [0.0] * 3}))
    assert from_frame.field == "DataFrame row 2 column 't'"
    assert from_file.field.endswith("line 4 column 't'")
    assert from_frame.expected == from_file.expected == "strictly increasing times"


def test_a_non_integer_mode_is_refused():
    with pytest.raises(ModelError) as err:
        read_log(pd.DataFrame({"u": [0.0, 0.0], "y": [0.0, 0.0], "q": [0.0, 0.5]}), _Sys)
    assert err.value.field == "DataFrame row 1 column 'q'"


@pytest.mark.parametrize("column, field, got", [
    ([1.0, np.nan], "DataFrame row 1 column 'y'", "nan"),
    ([np.inf, 1.0], "DataFrame row 0 column 'y'", "inf"),
    (["1.0", "2.0"], "DataFrame column 'y'", "dtype"),
    ([True, False], "DataFrame column 'y'", "dtype bool"),
])
def test_bad_cells_and_columns(column, field, got):
    with pytest.raises(ModelError) as err:
        read_log(pd.DataFrame({"u": [0.0, 1.0], "y": column}), _Sys)
    assert err.value.field == field
    assert got in err.value.got


def test_nullable_integers_are_numbers_and_missing_ones_are_refused():
    log = read_log(pd.DataFrame({"u": pd.array([1, 2], dtype="Int64"), "y": [0.0, 1.0]}), _Sys)
    np.testing.assert_array_equal(log.U[:, 0], [1.0, 2.0])
    with pytest.raises(ModelError) as err:
        read_log(pd.DataFrame({"u": pd.array([1, None], dtype="Int64"), "y": [0.0, 1.0]}), _Sys)
    assert err.value.field == "DataFrame row 1 column 'u'"


def test_a_named_index_and_non_string_columns_are_refused():
    df = pd.DataFrame({"t": [0.0, 1.0], "u": [0.0, 1.0], "y": [0.0, 1.0]}).set_index("t")
    with pytest.raises(ModelError) as err:
        read_log(df, _Sys)
    assert err.value.field == "DataFrame index" and "reset_index" in err.value.expected
    log = read_log(df.reset_index(), _Sys)
    np.testing.assert_array_equal(log.t, [0.0, 1.0])
    with pytest.raises(ModelError) as err:
        read_log(pd.DataFrame({"u": [0.0], "y": [0.0], 3: [1.0]}), _Sys)
    assert err.value.field == "DataFrame columns"


def test_a_repeated_column_with_other_values_and_an_empty_frame():
    df = pd.DataFrame([[0.0, 1.0, 2.0]], columns=["u", "y", "y"])
    with pytest.raises(ModelError) as err:
        read_log(df, _Sys)
    assert err.value.field == "DataFrame row 0 column 'y'"
    with pytest.raises(ModelError) as err:
        read_log(pd.DataFrame({"u": [], "y": []}), _Sys)
    assert err.value.field == "DataFrame" and "at least one sample" in err.value.expected


def test_missing_pandas_names_the_extra(monkeypatch):
    import sys

    _, trace = _rotation_trace()
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ModelError) as err:
        trace.to_pandas()
    assert err.value.field == "pandas" and "hybobs_opt[interop]" in err.value.expected

"""One CLI vocabulary: ``--version``; ``--horizon/-T`` with one default; ``--out`` a file and
``--out-dir`` a directory everywhere, ``--observers`` a list, ``--ts`` the sampling period (old
spellings kept as hidden aliases that warn); one kind of value per option name across commands
(the kinds declared in :mod:`hybobs_opt.cli._vocabulary`); ``--param`` wherever a system is built."""

from __future__ import annotations

import argparse
import json

import pytest

from hybobs_opt import __version__
from hybobs_opt.cli import build_parser, main
from hybobs_opt.defaults import DEFAULT_HORIZON


def _subparsers():
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _options(p):
    return {s: a for a in p._actions for s in a.option_strings}


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"hybobs {__version__}"


def test_every_horizon_option_is_horizon_or_T_with_the_one_default():
    seen = 0
    for name, p in _subparsers().items():
        opts = _options(p)
        if "--horizon" not in opts:
            continue
        seen += 1
        a = opts["--horizon"]
        assert "-T" in a.option_strings and not a.required, name
        # None means "the default, or the horizon of a --regions file"; the help says which
        assert a.default in (DEFAULT_HORIZON, None) and f"default {DEFAULT_HORIZON}" in a.help, name
    assert seen >= 4  # regions, observe, bench, report


def test_out_is_a_file_and_out_dir_a_directory():
    for name, p in _subparsers().items():
        opts = _options(p)
        if "--out-dir" in opts:
            assert opts["--out-dir"].metavar == "DIR", name
        if "--out" in opts and opts["--out"] is not opts.get("--out-dir"):
            assert opts["--out"].metavar != "DIR", name
    subs = _subparsers()
    assert "--out-dir" in _options(subs["report"]) and "--out-dir" in _options(subs["diagnose"])
    # the old spelling parses as the new option, and is not one of its listed option strings
    assert subs["regions"]._option_string_actions["--save"] is _options(subs["regions"])["--out"]
    assert "--save" not in _options(subs["regions"])


def test_one_kind_of_value_per_option_name_across_commands():
    """An option name means one kind of value (file, directory, number, list, flag ...) in every command."""
    from hybobs_opt.cli._vocabulary import option_kind, visible_options

    kinds: dict[str, dict[str, list[str]]] = {}
    for name, p in _subparsers().items():
        for action in visible_options(p):
            for option in action.option_strings:
                kinds.setdefault(option, {}).setdefault(option_kind(action), []).append(name)
    mixed = {o: k for o, k in kinds.items() if len(k) > 1}
    assert not mixed, f"option names with several kinds of value: {mixed}"
    # the conventions the issue fixed, spelled out
    assert list(kinds["--out"]) == ["file"] and list(kinds["-o"]) == ["file"]
    assert list(kinds["--out-dir"]) == ["directory"]
    assert list(kinds["--observers"]) == ["list"] and sorted(kinds["--observers"]["list"]) == ["bench", "observe"]
    assert list(kinds["--ts"]) == ["seconds"] and sorted(kinds["--ts"]["seconds"]) == ["regions", "simulate"]
    assert "--observer" not in kinds and "--dt" not in kinds and "--csv" not in kinds and "--save" not in kinds


def test_every_option_value_has_a_declared_kind_and_the_matching_type():
    """Each value-taking option uses a metavar of the declared table, and a numeric kind converts
    its value with the declared type (a number option without ``type=float`` would hand on text)."""
    from hybobs_opt.cli._vocabulary import KIND_TYPES, option_kind, visible_options

    for name, p in _subparsers().items():
        for action in visible_options(p):
            kind = option_kind(action).replace(" (repeatable)", "")  # KeyError: an undeclared metavar
            assert action.type is KIND_TYPES.get(kind), (name, action.option_strings, kind, action.type)


#: The old spellings that still parse (hidden, with a FutureWarning): command -> old -> new.
OLD_SPELLINGS = {
    "simulate": {"--dt": "--ts", "--csv": "--out"},
    "observe": {"--observer": "--observers"},
    "regions": {"--save": "--out"},
    "report": {"--out": "--out-dir"},
    "export": {"--out": "--out-dir"},
    "diagnose": {"--out": "--out-dir"},
}


def test_old_spellings_parse_warn_and_are_hidden_from_help():
    import re
    import warnings

    from hybobs_opt.cli._vocabulary import hidden_aliases

    subs = _subparsers()
    assert {name: hidden_aliases(p) for name, p in subs.items() if hidden_aliases(p)} == OLD_SPELLINGS
    for name, renamed in OLD_SPELLINGS.items():
        p = subs[name]
        text = p.format_help()
        for old, new in renamed.items():
            assert not re.search(re.escape(old) + r"(?![-\w])", text), (name, old)  # --out-dir is not --out
            assert re.search(re.escape(new) + r"(?![-\w])", text), (name, new)
            action = p._option_string_actions[new]
            value = ["0.5"] if action.type is float else ["x.csv"]
            system = [] if name == "report" else ["powertrain3"]
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                ns = p.parse_args([*system, old, *value] + (["--out-dir", "d"] if name == "report" and old != "--out" else []))
            assert getattr(ns, action.dest) == (0.5 if action.type is float else "x.csv"), (name, old)
            assert [str(w.message) for w in caught if issubclass(w.category, FutureWarning)] == [
                f"{old} is deprecated and goes in hybobs_opt 0.2.0: use {new}"]


def test_short_options_are_the_conventional_ones():
    """``-o`` is ``--out`` (a file) wherever there is one, ``-T`` the horizon; ``-v`` stays free for ``--verbose``."""
    for name, p in _subparsers().items():
        opts = _options(p)
        short = sorted(s for s in opts if not s.startswith("--") and s != "-h")
        assert set(short) <= {"-o", "-T"}, (name, short)
        if "--out" in opts:
            assert opts["--out"] is opts["-o"], name
        if "-T" in opts:
            assert opts["-T"] is opts["--horizon"], name


def test_report_help_lists_the_sections_without_importing_the_report():
    """``report --help`` lists the section keys from a static list (importing the report's sections took
    seconds); the list is the report's own."""
    import subprocess
    import sys

    from hybobs_opt.cli.report import SECTION_KEYS
    from hybobs_opt.report.html import section_keys

    assert list(SECTION_KEYS) == section_keys()
    probe = ("import sys, contextlib, io\nfrom hybobs_opt.cli import main\n"
             "with contextlib.redirect_stdout(io.StringIO()) as buf:\n    main(['report', '--help'])\n"
             "print('observers' in buf.getvalue(), 'hybobs_opt.report' in sys.modules, 'numpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["True", "False", "False"]


def test_report_order_does_not_depend_on_which_section_was_imported_first():
    """A section registers when its module is imported; the report's order must not follow that."""
    import subprocess
    import sys

    from hybobs_opt.cli.report import SECTION_KEYS

    probe = ("import hybobs_opt.report.drift_section, hybobs_opt.report.observers_section\n"
             "from hybobs_opt.report.html import section_keys\nprint(','.join(section_keys()))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.strip()
    assert out.split(",") == list(SECTION_KEYS)


def test_param_wherever_a_system_is_built():
    for name, p in _subparsers().items():
        positional = [a.metavar for a in p._actions if not a.option_strings]
        if "SYSTEM" in positional:
            assert "--param" in _options(p), name


def test_regions_out_and_its_deprecated_name_write_the_same_file(tmp_path, capsys):
    import warnings

    for flag in ("--out", "--save"):
        path = tmp_path / f"r{flag.strip('-')}.json"
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert main(["regions", "powertrain3", flag, str(path), "--json"]) == 0
        future = [str(w.message) for w in caught if issubclass(w.category, FutureWarning)]
        # the old spelling works for one release and says what to write instead
        assert future == ([] if flag == "--out" else ["--save is deprecated and goes in hybobs_opt 0.2.0: use --out"])
        assert json.loads(capsys.readouterr().out)["horizon"] == DEFAULT_HORIZON
        assert json.loads(path.read_text())["horizon"] == DEFAULT_HORIZON


def test_diagnose_writes_no_report_unless_asked(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["diagnose", "vehicle_tracking", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["report"] is None
    assert not any(tmp_path.iterdir())
    assert main(["diagnose", "vehicle_tracking", "--out-dir", "d", "--json"]) == 0
    paths = json.loads(capsys.readouterr().out)["report"]
    assert paths and (tmp_path / "d").is_dir()


def test_simulate_and_regions_plots_get_the_examples_units(tmp_path, monkeypatch):
    """The figures of ``simulate --plot`` and ``regions --plot`` label their axes "name [unit]" with
    the example's units (issue 17), as the report does."""
    import hybobs_opt.report.plots as plots

    seen = {}
    real_trace, real_cut = plots.plot_trace, plots.plot_region_cut

    def trace(*a, **kw):
        seen["trace"] = kw.get("units")
        return real_trace(*a, **kw)

    def cut(*a, **kw):
        seen["cut"] = kw.get("units")
        return real_cut(*a, **kw)

    monkeypatch.setattr(plots, "plot_trace", trace)
    monkeypatch.setattr(plots, "plot_region_cut", cut)
    assert main(["simulate", "powertrain3", "--t-final", "0.05", "--plot", str(tmp_path / "s.png")]) == 0
    assert main(["regions", "powertrain3", "-T", "3", "--cut", "omega_l=25", "--resolution", "6x5", "--no-cache",
                 "--plot", str(tmp_path / "c.png")]) == 0
    assert seen["trace"] == seen["cut"] == {"theta": "rad", "omega_m": "rad/s", "omega_l": "rad/s"}
    assert (tmp_path / "s.png").stat().st_size > 0 and (tmp_path / "c.png").stat().st_size > 0


def test_cli_json_is_strict(capsys):
    """``--json`` output is strict JSON: a NaN or an infinity is ``null`` (strict parsers refuse ``NaN``)."""
    import json

    import numpy as np

    from hybobs_opt.cli._common import print_json

    print_json({"a": float("nan"), "b": [1.0, float("inf"), np.float64("-inf")], "c": np.array([np.nan, 2.0]),
                "d": (np.float32(1.5), True, None, "NaN")})
    text = capsys.readouterr().out

    def refuse(name):
        raise ValueError(name)

    assert json.loads(text, parse_constant=refuse) == {"a": None, "b": [1.0, None, None], "c": [None, 2.0],
                                                        "d": [1.5, True, None, "NaN"]}

"""Outputs: every path a command writes is checked before the computation; an existing file is
replaced only with ``--force``; a symbolic link at an output path (or inside an output directory)
is never followed, not even with ``--force``.

Oracle: the file system itself (the planted file keeps its bytes, the link's target is untouched)
and the order of the work: the command's computation is replaced by a function that fails the
test, so a refusal that came after it would show.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hybobs_opt.cli import main

ORIGINAL = b"the user's own file\n"


def _boom(*args, **kwargs):
    raise AssertionError("the computation ran before the output path was checked")


def _plant(path: Path) -> Path:
    path.write_bytes(ORIGINAL)
    return path


#: (argv with {out}, option, command module, the first step of its work: replaced by _boom)
COMMANDS = {
    "regions --out": (["regions", "powertrain3", "-T", "3", "--no-cache", "--out", "{out}"], "--out",
                      "regions", "load_system"),
    "regions --plot": (["regions", "powertrain3", "-T", "3", "--no-cache", "--cut", "theta=0", "--plot", "{out}.png"],
                       "--plot", "regions", "load_system"),
    "simulate --out": (["simulate", "powertrain3", "--t-final", "0.01", "--out", "{out}"], "--out",
                       "simulate", "load_system"),
    "synth --out": (["synth", "vehicle_tracking", "--out", "{out}"], "--out", "synth", "design_setup"),
    "model export --out": (["model", "export", "powertrain3", "--out", "{out}.toml"], "--out", "model", "load_system"),
}


def _argv(argv: list[str], out: Path) -> list[str]:
    return [a.replace("{out}", str(out)) for a in argv]


def _target(argv: list[str], out: Path) -> Path:
    option = next(a for a in argv if "{out}" in a)
    return Path(option.replace("{out}", str(out)))


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_an_existing_file_is_refused_before_the_work_and_kept(name, tmp_path, monkeypatch, capsys):
    argv, option, module, func = COMMANDS[name]
    target = _plant(_target(argv, tmp_path / "out"))
    import importlib

    monkeypatch.setattr(importlib.import_module(f"hybobs_opt.cli.{module}"), func, _boom)
    assert main(_argv(argv, tmp_path / "out")) == 2
    err = capsys.readouterr().err
    assert option in err and "--force" in err and "exists" in err, err
    assert target.read_bytes() == ORIGINAL


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_a_symbolic_link_is_never_followed_even_with_force(name, tmp_path, capsys):
    argv, option, _, _ = COMMANDS[name]
    victim = _plant(tmp_path / "victim")
    link = _target(argv, tmp_path / "out")
    link.symlink_to(victim)
    assert main([*_argv(argv, tmp_path / "out"), "--force"]) == 2
    err = capsys.readouterr().err
    assert option in err and "symbolic link" in err, err
    assert victim.read_bytes() == ORIGINAL and link.is_symlink()


def test_force_replaces_an_existing_file(tmp_path, capsys):
    out = _plant(tmp_path / "trace.csv")
    assert main(["simulate", "powertrain3", "--t-final", "0.01", "--out", str(out), "--force"]) == 0
    assert out.read_text().startswith("t,")
    log = tmp_path / "log.csv"
    assert main(["simulate", "powertrain3", "--t-final", "0.02", "--out", str(log)]) == 0
    out = _plant(tmp_path / "estimates.csv")
    assert main(["observe", "powertrain3", "--data", str(log), "--out", str(out), "--force", "--json"]) == 0
    assert out.read_text().startswith("t,")
    capsys.readouterr()


def test_observe_refuses_an_existing_estimates_file_before_the_run(tmp_path, monkeypatch, capsys):
    log = tmp_path / "log.csv"
    assert main(["simulate", "powertrain3", "--t-final", "0.02", "--out", str(log)]) == 0
    out = _plant(tmp_path / "estimates.csv")
    monkeypatch.setattr("hybobs_opt.cli.observe.load_system", _boom)
    assert main(["observe", "powertrain3", "--data", str(log), "--out", str(out), "--no-cache"]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "--force" in err and out.read_bytes() == ORIGINAL


@pytest.mark.parametrize("command", [["report", "--section", "drift"], ["diagnose", "vehicle_tracking"]])
def test_an_output_directory_with_a_link_inside_is_refused(command, tmp_path, capsys):
    out = tmp_path / "rep"
    out.mkdir()
    victim = _plant(tmp_path / "victim")
    (out / "index.html").symlink_to(victim)
    assert main([*command, "--out-dir", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    assert "--out-dir" in err and "symbolic link" in err, err
    assert victim.read_bytes() == ORIGINAL


def test_a_second_report_into_the_same_directory_needs_force(tmp_path, capsys):
    out = tmp_path / "rep"
    assert main(["report", "--section", "drift", "--out-dir", str(out), "--json"]) == 0
    first = (out / "index.html").read_bytes()
    capsys.readouterr()
    assert main(["report", "--section", "drift", "--out-dir", str(out)]) == 2
    err = capsys.readouterr().err
    assert "index.html" in err and "--force" in err, err
    assert (out / "index.html").read_bytes() == first
    assert main(["report", "--section", "drift", "--out-dir", str(out), "--force", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["sections"]


def test_the_first_steps_named_in_the_table_exist():
    """The table names what each command calls first (a renamed one would make the ordering check
    above vacuous)."""
    import importlib

    for _, _, module, func in COMMANDS.values():
        assert callable(getattr(importlib.import_module(f"hybobs_opt.cli.{module}"), func))


def test_the_library_writers_never_write_through_a_link(tmp_path):
    """The writers behind the commands open their file with ``O_NOFOLLOW``: a link planted after
    the command's check (or handed to the library directly) is refused, its target untouched."""
    from hybobs_opt.errors import ModelError
    from hybobs_opt.regions import analyse_observability, save_analysis
    from hybobs_opt.sim import simulate_pwa
    from hybobs_opt.studies.paper002_powertrain.systems import powertrain3
    from hybobs_opt.systems import save_model

    import numpy as np

    system = powertrain3()
    trace = simulate_pwa(system, np.array([0.06, 39.0, 3.25]), np.zeros((5, 1)))
    analysis = analyse_observability(system, 3)
    writers = {
        "model.toml": lambda p: save_model(system, p),
        "trace.csv": lambda p: trace.to_csv(p),
        "regions.json": lambda p: save_analysis(analysis, p),
    }
    for name, write in writers.items():
        victim = _plant(tmp_path / f"victim-{name}")
        link = tmp_path / name
        link.symlink_to(victim)
        with pytest.raises(ModelError, match="symbolic link"):
            write(link)
        assert victim.read_bytes() == ORIGINAL, name
        link.unlink()
        write(link)  # the same writer, a plain path: written
        assert link.is_file() and not link.is_symlink() and link.stat().st_size > 0

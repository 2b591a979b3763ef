"""Long logs stream: ``read_log`` parses a CSV log row by row into arrays (never the whole file as
text and Python lists: reading took about 9x the file's size), and its messages name the line
of the file, blank lines counted.

Oracles: ``tracemalloc`` (NumPy reports its buffers to it) against the file's size, and
``numpy.loadtxt`` for the values.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from canonical import deadzone_spring
from hybobs_opt.errors import ModelError
from hybobs_opt.sim import log as log_module
from hybobs_opt.sim.log import read_log


def _write_log(path, rows: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    data = np.column_stack([np.arange(rows) * 1e-3, rng.uniform(-1, 1, rows), rng.uniform(-1, 1, rows)])
    with path.open("w") as fh:
        fh.write("t,u,y\n")
        for r in data:
            fh.write(f"{float(r[0])!r},{float(r[1])!r},{float(r[2])!r}\n")
    return data


def test_reading_a_long_log_takes_less_than_twice_its_size(tmp_path):
    path = tmp_path / "long.csv"
    _write_log(path, 120_000)
    size = path.stat().st_size
    tracemalloc.start()
    try:
        log = read_log(path, deadzone_spring())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert log.n_samples == 120_000
    assert peak <= 2 * size, f"peak {peak / 1e6:.1f} MB for a {size / 1e6:.1f} MB log"


def test_the_values_equal_an_independent_parse_across_blocks(tmp_path, monkeypatch):
    path = tmp_path / "log.csv"
    data = _write_log(path, 1000, seed=3)
    monkeypatch.setattr(log_module, "LOG_BLOCK_ROWS", 7)  # many blocks, one partial
    log = read_log(path, deadzone_spring())
    ref = np.loadtxt(path, delimiter=",", skiprows=1)
    assert np.array_equal(ref, data)
    assert np.array_equal(log.t, ref[:, 0]) and np.array_equal(log.U[:, 0], ref[:, 1]) and np.array_equal(log.Y[:, 0], ref[:, 2])


@pytest.mark.parametrize("block", [7, 65536])
@pytest.mark.parametrize("body, line, what", [
    ("0,0.1,0.2\n\n\n0,0.2,0.3\n", 5, "strictly increasing"),  # the second time, after two blank lines
    ("0,0.1,0.2\n1,0.1,0.2\n\n2,0.2,0.3,4\n", 5, "cells"),
])
def test_messages_name_the_line_blank_lines_counted(tmp_path, monkeypatch, block, body, line, what):
    monkeypatch.setattr(log_module, "LOG_BLOCK_ROWS", block)
    path = tmp_path / "log.csv"
    path.write_text("t,u,y\n\n" + body)
    with pytest.raises(ModelError, match=rf"line {line + 1}\b.*{what}|line {line + 1}\b") as err:
        read_log(path, deadzone_spring())
    assert what in str(err.value), str(err.value)


def test_a_repeated_column_and_a_mode_name_their_line(tmp_path):
    from hybobs_opt.studies.paper002_powertrain.systems import powertrain3

    system = powertrain3()
    head = "t,T_m,omega_m,theta,omega_l,q\n"
    path = tmp_path / "dup.csv"
    # omega_m is an output and a state: its two columns must agree; the mode must be an integer
    path.write_text(head.replace("q", "omega_m") + "0,1,2,0,3,2\n\n\n1,1,2,0,3,2.5\n")
    with pytest.raises(ModelError, match=r"line 5 column 'omega_m'"):
        read_log(path, system)
    path = tmp_path / "mode.csv"
    path.write_text(head + "0,1,2,0,3,0\n\n1,1,2,0,3,0.5\n")
    with pytest.raises(ModelError, match=r"line 4 column 'q'"):
        read_log(path, system)

"""Files are data, never code: text from a model file reaches generated C only escaped.

The attack of the hostile-input campaign: a model ``name`` holding ``*\\`` + newline + ``/`` (C
splices a backslash-newline before it strips comments, so the header comment closes and the rest
of the name is compiled; ``??/`` is a backslash in C99 too) with a guarded constructor that would
print a marker before the driver's ``main``.  Oracle: the C compiler itself (``-std=c99 -Wall
-Werror -pedantic``), the driver's output, and the generated text (no user text outside a literal
or a transliterated comment).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from hybobs_opt.cli import main
from hybobs_opt.observers.c_export import _c_string, _comment

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from c_replay import code_only  # noqa: E402
from canonical import deadzone_spring  # noqa: E402

from hybobs_opt.systems import save_model  # noqa: E402

PAYLOAD = '__attribute__((constructor)) static void hb_pwn(void) { puts("PWNED"); }'
HOSTILE_NAMES = [
    "*\\\n/ " + PAYLOAD + " /*",
    "??/\n*/ " + PAYLOAD + " /*",
    "x */ " + PAYLOAD + " /* y",
    '"; ' + PAYLOAD + ' char* s = "',
    "\u202e\u0000 */\r\n" + PAYLOAD,
]


def _model(tmp_path: Path, name: str) -> Path:
    path = tmp_path / "model.json"
    save_model(deadzone_spring(), path)
    data = json.loads(path.read_text())
    data["name"] = name
    path.write_text(json.dumps(data))
    return path


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("name", HOSTILE_NAMES, ids=range(len(HOSTILE_NAMES)))
def test_a_hostile_model_name_never_compiles_into_the_export(tmp_path, capsys, name):
    model = _model(tmp_path, name)
    out = tmp_path / "c"
    code = main(["export", str(model), "-T", "2", "--out-dir", str(out), "--json", "--no-cache"])
    captured = capsys.readouterr()
    if code != 0:  # refusing the name is an answer too, as one line
        assert code == 2 and "PWNED" not in captured.out
        return
    assert json.loads(captured.out)["build"]["built"] is True  # strict C99, no warning
    for f in out.iterdir():
        text = f.read_text()
        # no line splice, no trigraph: comments and literals end where they appear to
        assert "\\\n" not in text and "??" not in text, f.name
        assert "hb_pwn" not in code_only(text) and "PWNED" not in code_only(text), f.name
    exe = tmp_path / "driver"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-pedantic", "-O2", str(out / "hybobs_lookup.c"),
                    str(out / "hybobs_lookup_driver.c"), "-lm", "-o", str(exe)], check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True)
    assert "PWNED" not in r.stdout + r.stderr and r.returncode != 0  # its usage message, nothing before


def test_comments_and_literals_hold_no_active_character():
    for text in HOSTILE_NAMES + ["a/*b*/c", "\\", "?" * 5, "é\u2028\u2029"]:
        c = _comment(text)
        assert not any(bad in c for bad in ("*/", "/*", "\\", "?", "\n", "\r", '"')), c
        lit = _c_string(text)
        body = lit[1:-1]
        assert "?" not in body and "\n" not in body and '"' not in body
        # every backslash starts a three-digit octal escape: the literal's bytes are the text's
        i = 0
        out = bytearray()
        while i < len(body):
            if body[i] == "\\":
                out.append(int(body[i + 1:i + 4], 8))
                i += 4
            else:
                out += body[i].encode()
                i += 1
        assert out.decode("utf-8") == text


def test_existing_files_and_planted_links_are_refused_before_any_work(tmp_path, capsys):
    model = _model(tmp_path, "spring")
    out = tmp_path / "c"
    out.mkdir()
    target = tmp_path / "elsewhere.txt"
    target.write_text("keep me")
    os.symlink(target, out / "hybobs_lookup.c")
    assert main(["export", str(model), "-T", "2", "--out-dir", str(out), "--force", "--no-build"]) == 2
    assert "symbolic link" in capsys.readouterr().err and target.read_text() == "keep me"
    (out / "hybobs_lookup.c").unlink()
    (out / "hybobs_lookup.h").write_text("mine")
    assert main(["export", str(model), "-T", "2", "--out-dir", str(out), "--no-build"]) == 2
    assert "--force" in capsys.readouterr().err and (out / "hybobs_lookup.h").read_text() == "mine"
    assert main(["export", str(model), "-T", "2", "--out-dir", str(out), "--no-build", "--force"]) == 0
    assert (out / "hybobs_lookup.h").read_text() != "mine"

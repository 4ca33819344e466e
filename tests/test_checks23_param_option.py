"""A bad ``--param`` is said at the option as typed, in the words a file's value gets.

Until 2026-12-01 ``pirate-bt run t.yaml --param d=1e999s`` put the error at
``--param:1:1:``, naming no option (with several ``--param`` the reader had to guess
which), and a 5,000-digit number given to ``--param`` was *expected a finite number*
(an angle's *needs a unit*, an integer's *expected an integer*) where the same number
in a tree file is *a number of 5000 digits is too long* (docs/trees.md).
"""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.treefile import load_tree

_TREE = (
    "params:\n"
    "  d: {type: duration, default: 1 s}\n"
    "  n: {type: number, default: 1}\n"
    "  i: {type: integer, default: 1}\n"
    "  roll: {type: angle, default: 0 deg}\n"
    "root: {type: wait, duration: $d}\n"
)
_LONG = "9" * 5000


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    path = tmp_path / "t.yaml"
    path.write_text(_TREE, encoding="utf-8")
    return path


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert out == "" and len(lines) == 1, err
    assert "--param:1:1" not in lines[0], lines
    return lines[0].removeprefix("pirate-bt: ")  # validate says its files' lines bare


def test_a_bad_param_is_said_at_the_option_that_gave_it(
    tree: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["run", str(tree), "--quiet", "--param", "n=2", "--param", "d=1e999s"]
    assert main(argv) == 2
    line = _one_line(capsys)
    assert line.startswith("--param d=1e999s: parameter 'd': "), line
    assert line.endswith("'1e999s' is not a finite number"), line
    assert main(["validate", "--param", "nope=3", str(tree)]) == 2
    assert _one_line(capsys).startswith("--param nope=3: unknown parameter 'nope'")


@pytest.mark.parametrize("name", ["n", "i", "roll"])
def test_a_number_too_long_is_said_as_a_file_says_it(
    tree: Path, tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", "--param", f"{name}={_LONG}", str(tree)]) == 2
    line = _one_line(capsys)
    assert line.startswith(f"--param {name}=999"), line
    assert line.endswith(f"parameter '{name}': a number of 5000 digits is too long"), line
    # the file loader's words for the same number written as the default
    written = tmp_path / "w.yaml"
    written.write_text(_TREE.replace("default: 1}", f"default: {_LONG}}}", 1), encoding="utf-8")
    assert main(["validate", str(written)]) == 2
    assert _one_line(capsys).endswith(": a number of 5000 digits is too long")


def test_a_line_break_in_a_value_keeps_the_error_on_one_line(
    tree: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", "--param", "d=1\n2 s", str(tree)]) == 2
    assert _one_line(capsys).startswith("--param d=1\\n2 s: parameter 'd': ")


def test_the_error_stays_the_command_lines_for_the_code_that_reads_it(tree: Path) -> None:
    # campaigns place a --param problem at the run's own params by its file and words
    with pytest.raises(ValidationFailed) as info:
        load_tree(tree, params={"d": "5 m"}, params_from_text=True, params_origin="--param")
    (error,) = info.value.errors
    assert error.location.file == "--param"
    assert error.message.startswith("parameter 'd': ")
    assert str(error).startswith("--param d=5 m: parameter 'd': ")
    again = pickle.loads(pickle.dumps(error))  # across a process pool, intact
    assert str(again) == str(error) and again.location == error.location

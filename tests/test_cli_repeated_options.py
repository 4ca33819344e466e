"""An option given twice is refused in one line, not silently taken as its last value.

argparse keeps the last of a repeated option: ``mission lab.route --seed 1 ... --seed 2``
ran seed 2, and ``-o a.svg --output b.svg`` wrote only b.svg, with nothing said. The
command line now refuses a value option given twice (exit 2, one line naming it);
the options meant to be repeated (``--param``, ``--log``, ``--fault``...) still are.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

REPO = Path(__file__).resolve().parent.parent


def test_a_value_option_given_twice_is_refused_in_one_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    lab = str(REPO / "scenarios" / "lab.yaml")
    code = main(["validate", lab, "--kind", "network", "--kind", "tree"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1, err
    assert "--kind given twice" in err and "'network'" in err and "'tree'" in err


def test_an_option_and_its_other_spelling_are_one_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b = tmp_path / "a.dot", tmp_path / "b.dot"
    tree = REPO / "trees" / "straight.yaml"
    code = main(["render", str(tree), "-o", str(a), "--output", str(b)])
    err = capsys.readouterr().err
    assert code == 2 and "-o, then --output, given twice" in err, err
    assert not a.exists() and not b.exists()  # refused before anything was written


def test_options_meant_to_repeat_still_do(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(
        [
            "--log",
            "link=warning",
            "--log",
            "sim=warning",
            "validate",
            str(REPO / "trees" / "straight.yaml"),
        ]
    )
    assert code == 0, capsys.readouterr().err


def test_a_flag_given_twice_is_still_a_flag(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["--debug", "validate", "--debug", str(REPO / "trees" / "straight.yaml")])
    assert code == 0, capsys.readouterr().err

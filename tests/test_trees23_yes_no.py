"""A node's value written ``no``, ``yes``, ``on`` or ``off`` where text is meant
(docs/trees.md, Parameters and units).

YAML 1.1 (which the loader reads, as PyYAML does) takes a plain ``no`` for the boolean
false: ``{type: log, message: no}`` was refused as *must be text, not false*, a false
nobody wrote. The refusal now says how the word was read and how to keep it text.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(("word", "read"), [("no", "false"), ("Yes", "true"), ("off", "false")])
def test_a_yes_or_no_refused_where_text_is_meant_says_how_yaml_read_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], word: str, read: str
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "name: t\nroot:\n  type: sequence\n  children:\n"
        f"    - {{type: log, message: {word}}}\n"
        f"    - {{type: oneshot, on: {word}, child: success}}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    hint = f"(YAML reads a plain {word} as {read}: quote it for the text)"
    assert capsys.readouterr().err.replace(str(tree), "t.yaml").splitlines() == [
        f"t.yaml:5:19: log: message: must be text, not {read} {hint}",
        f"t.yaml:6:23: oneshot: on: {read} is not one of success, completion {hint}",
    ]


def test_true_and_a_quoted_no_keep_their_meaning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "name: t\nroot:\n  type: sequence\n  children:\n"
        "    - {type: log, message: 'no'}\n"
        "    - {type: drive, velocity: 10 mm/s, distance: 1 m, reverse: yes}\n"
        "    - {type: log, message: true}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2  # a boolean for a boolean stays one
    assert capsys.readouterr().err.replace(str(tree), "t.yaml") == (
        "t.yaml:7:19: log: message: must be text, not true\n"
    )


def test_a_parameter_s_declaration_and_a_call_s_value_say_it_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "name: t\nroot: {type: subtree, ref: s, params: {m: no}}\nsubtrees:\n  s:\n"
        "    params:\n      m: {type: string}\n      side: {type: string, choices: [on, x],"
        " default: x}\n    root: {type: log, message: $m}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert sorted(capsys.readouterr().err.replace(str(tree), "t.yaml").splitlines()) == [
        "t.yaml:2:40: parameter 'm': expected a string, got False"
        " (YAML reads a plain no as false: quote it for the text)",
        "t.yaml:7:38: choices: must be text, not true"
        " (YAML reads a plain on as true: quote it for the text)",
    ]

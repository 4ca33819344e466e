"""Probe 8 (hostile trees): YAML values that are no JSON value.

PyYAML's safe loader builds bytes (``!!binary``), sets (``!!set``), lists of pairs
(``!!omap``, ``!!pairs``) and dates (a bare ``2001-12-14``). A tree with one as a
blackboard default or a log message validated and ran (bytes pass a text check), and
``pirate-bt export btcpp`` then failed with exit 1, *internal error: TypeError: Object
of type bytes is not JSON serializable*.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.yamlfile import load_yaml_text


@pytest.mark.parametrize(
    ("value", "column", "what"),
    [
        ("!!binary aGVsbG8=", 29, "!!binary (bytes)"),
        ("!!set {a, b}", 29, "!!set"),
        ("!!omap [a: 1]", 29, "!!omap"),
        ("!!pairs [a: 1]", 29, "!!pairs"),
    ],
)
@pytest.mark.parametrize("verb", ["validate", "export"])
def test_a_value_that_is_no_json_value_is_refused_where_written(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    value: str,
    column: int,
    what: str,
    verb: str,
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text(
        f"blackboard:\n  d: {{default: {value}}}\nroot: {{type: check_blackboard, key: d,"
        " op: is_set}\n",
        encoding="utf-8",
    )
    args = ["validate", str(tree)]
    if verb == "export":
        args = ["export", "btcpp", str(tree), "-o", str(tmp_path / "tree.xml")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"tree.yaml:2:16: a YAML {what} value is not allowed here" in err
    assert not (tmp_path / "tree.xml").exists()


def test_bytes_are_not_taken_for_text_nor_a_key(tmp_path: Path) -> None:
    with pytest.raises(ValidationFailed) as caught:
        load_yaml_text("root: {type: log, message: !!binary aGk=, !!binary aGk=: x}\n", "t.yaml")
    assert [str(e) for e in caught.value.errors] == [
        "t.yaml:1:43: a YAML !!binary (bytes) value is not allowed here: write text, a"
        " number, a list or a mapping",
        "t.yaml:1:28: a YAML !!binary (bytes) value is not allowed here: write text, a"
        " number, a list or a mapping",
    ]


def test_a_bare_date_is_the_text_written(tmp_path: Path) -> None:
    doc = load_yaml_text("2001-12-14: [2001-12-14t21:59:43.10-05:00, !!timestamp 2002-1-1]\n")
    assert doc.data == {"2001-12-14": ["2001-12-14t21:59:43.10-05:00", "2002-1-1"]}
    tree = tmp_path / "tree.yaml"
    tree.write_text(
        "blackboard: {d: {type: string}}\n"
        "root: {type: set_blackboard, key: d, value: 2001-12-14}\n",
        encoding="utf-8",
    )
    assert main(["export", "btcpp", str(tree), "-o", str(tmp_path / "tree.xml")]) == 0
    assert 'value="2001-12-14"' in (tmp_path / "tree.xml").read_text(encoding="utf-8")
    assert (
        main(["import", "btcpp", str(tmp_path / "tree.xml"), "-o", str(tmp_path / "back.yaml")])
        == 0
    )
    assert main(["run", str(tmp_path / "back.yaml"), "--quiet"]) == 0


@pytest.mark.parametrize(
    ("written", "message"),
    [
        ("010", "010 has a leading zero, which YAML 1.1 reads as an octal number (8): write 10"),
        (
            "-0_10",
            "-0_10 has a leading zero, which YAML 1.1 reads as an octal number (-8): write -10",
        ),
    ],
)
def test_a_leading_zero_is_refused_not_read_as_octal(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], written: str, message: str
) -> None:
    # retry: attempts: 010 ran 8 attempts (YAML 1.1's octal).
    tree = tmp_path / "tree.yaml"
    tree.write_text(f"root: {{type: retry, attempts: {written}, child: success}}\n")
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err
    assert err == f"{tree}:1:31: {message}, or quote it for text\n"


def test_base_60_is_the_text_written() -> None:
    # YAML 1.1 read 1:30 as 90 and 10:30:15.5 as 37815.5: a log message "10:30" was a
    # number, a retry's "attempts: 1:20" 80 attempts.
    doc = load_yaml_text("a: 1:30\nb: [10:30:15.5, -1:00, '010', 0x10, 1_000, 0, 0.5]\n10:30: x\n")
    assert doc.data == {
        "a": "1:30",
        "b": ["10:30:15.5", "-1:00", "010", 16, 1000, 0, 0.5],
        "10:30": "x",
    }


@pytest.mark.parametrize(
    "text",
    [
        "root:\n  type: log\n  message: hi\n  ? {key}\n  : 1\n",  # a node's unknown key
        "params:\n  x:\n    type: number\n    ? {key}\n    : 1\nroot: success\n",
        "blackboard:\n  x:\n    type: number\n    ? {key}\n    : 1\nroot: success\n",
    ],
)
def test_an_unknown_key_of_any_length_is_cut_short(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    # An explicit key ("? KEY") may be longer than the 1024 characters of a plain one.
    tree = tmp_path / "tree.yaml"
    tree.write_text(text.format(key="k" * 5000), encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "unknown key 'kkkk" in err
    assert "(5000 characters)" in err
    assert len(err) < 300


@pytest.mark.parametrize(
    "text",
    [
        "root: success\n? {key}\n: 1\n? {key}\n: 2\n",  # a duplicate key
        "root:\n  type: sequence\n  children:\n"
        "    - {{type: success, name: {key}}}\n    - {{type: success, name: {key}}}\n",
        "blackboard:\n  ? {key} x\n  : {{type: number}}\nroot: success\n",
        "params:\n  ? {key} x\n  : {{type: number}}\nroot: success\n",
        "root:\n  type: parallel\n  policy: selected\n  selected: [{key}]\n  children: [success]\n",
    ],
)
def test_a_long_name_in_a_message_is_cut_short(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text(text.format(key="k" * 3000), encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err[:500]
    assert len(err) < 300, err[:300]

"""Every problem of a tree file is reported at once (docs/trees.md), not stage by stage.

The tree reader checks a file in stages (its YAML, its top level, its parameters, the
node walk, then the checks of the whole tree). A problem found by one stage used to
hide every problem the later stages would have found: a whole number with a leading
zero hid the whole file, a refused parameter ``default`` every node, a bad tree
``name`` or a duplicate node name the blackboard checks. Each file here has two
independent problems, and both are reported, each at its own line and column, through
``pirate-bt validate`` (one line each, exit 2) and through ``load_tree``; a problem
that follows from another (a node using the refused value) is not reported again.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.treefile import load_tree

WAIT_2_MM = "wait: '2 mm' is a length, but a time is expected (e.g. '1 s')"


def _validate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, *options: str
) -> tuple[Path, list[str]]:
    """``pirate-bt validate`` on ``text`` as tree.yaml: the file and its lines (exit 2)."""
    path = tmp_path / "tree.yaml"
    path.write_text(text, encoding="utf-8")
    code = main(["validate", *options, str(path)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and "internal error" not in err
    return path, [line for line in err.splitlines() if line.strip()]


def _load(path: Path) -> list[str]:
    """``load_tree``'s problems as ``line:column: message``, in their order."""
    with pytest.raises(ValidationFailed) as raised:
        load_tree(path)
    assert all(e.location.file == str(path) for e in raised.value.errors)
    return [f"{e.location.line}:{e.location.column}: {e.message}" for e in raised.value.errors]


def _both(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    text: str,
    expected: list[str],
    *options: str,
) -> None:
    """The command and the API report exactly ``expected`` (``line:column: message``)."""
    path, lines = _validate(tmp_path, capsys, text, *options)
    assert lines == [f"{path}:{problem}" for problem in expected]
    assert _load(path) == expected


# -- a whole number with a leading zero ------------------------------------------------

LEADING_ZERO = """\
name: t
root:
  type: sequence
  children:
    - type: retry
      attempts: 010
      child: success
    - {type: wait, duration: 2 mm}
"""


def test_a_leading_zero_no_longer_hides_the_nodes_problems(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The retry's attempts are not checked again (the refusal says what is wrong).
    refused = "010 has a leading zero, which YAML 1.1 reads as an octal number (8):"
    expected = [f"6:17: {refused} write 10, or quote it for text", f"8:20: {WAIT_2_MM}"]
    _both(tmp_path, capsys, LEADING_ZERO, expected, "--kind", "tree")
    # and without --kind: validate reads the file first to tell its kind, and that
    # reading stopped at the leading zero (pirate_bt/filekinds.py)
    _both(tmp_path, capsys, LEADING_ZERO, expected)


def test_a_leading_zero_where_a_value_is_declared_skips_what_uses_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = """\
params:
  times: {type: integer, default: 03}
blackboard:
  seen: {type: integer, default: 01}
root:
  type: sequence
  children:
    - {type: repeat, times: $times, child: success}
    - {type: check_blackboard, key: seen, op: is_set}
    - {type: wait, duration: 2 mm}
"""
    expected = [
        "2:35: 03 has a leading zero, which YAML 1.1 reads as an octal number (3):"
        " write 3, or quote it for text",
        "4:34: 01 has a leading zero, which YAML 1.1 reads as an octal number (1):"
        " write 1, or quote it for text",
        f"10:20: {WAIT_2_MM}",
    ]
    _both(tmp_path, capsys, text, expected, "--kind", "tree")


def test_a_leading_zero_in_a_subtree_file_hides_nothing_of_the_tree(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "step.yaml").write_text(
        "root: {type: retry, attempts: 02, child: {type: wait, duration: 3 mm}}\n",
        encoding="utf-8",
    )
    text = """\
root:
  type: sequence
  children:
    - {type: subtree, ref: step.yaml}
    - {type: wait, duration: 2 mm}
"""
    path, lines = _validate(tmp_path, capsys, text)
    step = tmp_path / "step.yaml"
    assert lines == [  # the file named first, then the subtree's
        f"{path}:5:20: {WAIT_2_MM}",
        f"{step}:1:31: 02 has a leading zero, which YAML 1.1 reads as an octal number (2):"
        " write 2, or quote it for text",
        f"{step}:1:55: wait: '3 mm' is a length, but a time is expected (e.g. '1 s')",
    ]
    with pytest.raises(ValidationFailed) as raised:
        load_tree(path)
    assert [str(e) for e in raised.value.errors] == lines


# -- a bad tree name --------------------------------------------------------------------

BAD_NAME = """\
name: 5
root:
  type: sequence
  children:
    - {type: wait, duration: 2 s}
    - {type: check_blackboard, key: ready, op: is_set}
"""


def test_a_bad_tree_name_no_longer_hides_the_blackboard_checks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    expected = [
        "1:1: name: must be text",
        "6:7: blackboard key 'ready' is read but not declared under 'blackboard:'",
    ]
    _both(tmp_path, capsys, BAD_NAME, expected)


def test_a_tree_name_with_a_slash_no_longer_hides_the_blackboard_checks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = BAD_NAME.replace("name: 5", "name: a/b")
    expected = [
        "1:1: name: must not contain '/' (used in node paths)",
        "6:7: blackboard key 'ready' is read but not declared under 'blackboard:'",
    ]
    _both(tmp_path, capsys, text, expected)


# -- a parameter's bad default -----------------------------------------------------------

BAD_DEFAULT = """\
params:
  pause: {type: duration, default: 5 mm}
  step: {type: duration, default: 1 s}
root:
  type: sequence
  children:
    - {type: wait, name: uses it, duration: $pause}
    - {type: wait, name: own, duration: 2 mm}
    - {type: wait, name: other, duration: $step}
"""


def test_a_bad_default_no_longer_hides_the_nodes_problems(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The node that uses $pause is not reported again: its value is the refused default.
    expected = [
        "2:27: default: '5 mm' is a length, but a time is expected (e.g. '1 s')",
        f"8:31: {WAIT_2_MM}",
    ]
    _both(tmp_path, capsys, BAD_DEFAULT, expected)


def test_a_bad_default_is_still_reported_when_a_value_is_given(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    expected = [
        "2:27: default: '5 mm' is a length, but a time is expected (e.g. '1 s')",
        f"8:31: {WAIT_2_MM}",
    ]
    _both(tmp_path, capsys, BAD_DEFAULT, expected, "--param", "pause=2s")


def test_a_bad_default_of_a_subtree_no_longer_hides_the_subtree_nor_the_call(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = """\
subtrees:
  hold:
    params: {count: {type: integer, default: two}}
    root: {type: repeat, times: $count, child: {type: wait, duration: 2 mm}}
root:
  type: sequence
  children:
    - {type: subtree, ref: hold}
    - {type: subtree, ref: hold, name: again, params: {cuont: 3}}
"""
    path, lines = _validate(tmp_path, capsys, text)
    assert len(lines) == 3, lines
    assert lines[0] == f"{path}:3:37: default: expected an integer, got 'two'"
    assert lines[1:] == [
        f"{path}:4:61: {WAIT_2_MM}",  # once, though the subtree is called twice
        f"{path}:9:56: unknown parameter 'cuont' (parameters: count)",
    ]
    assert [f"{path}:{problem}" for problem in _load(path)] == lines


# -- a duplicate node name ---------------------------------------------------------------

DUPLICATE = """\
blackboard:
  go: {type: boolean, external: maybe}
root:
  type: sequence
  children:
    - {type: check_blackboard, key: ready, op: is_set}
    - {type: wait, name: pause, duration: 1 s}
    - {type: wait, name: pause, duration: 1 s}
    - {type: check_blackboard, key: go, op: is_set}
"""


def test_a_duplicate_name_no_longer_hides_the_blackboard_checks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # In file order: the read of 'ready' (found last) comes before the duplicate. The
    # read of 'go' is not checked: its declaration is refused (said at line 2).
    path = tmp_path / "tree.yaml"
    expected = [
        "2:23: external: must be true or false, not 'maybe'",
        "6:7: blackboard key 'ready' is read but not declared under 'blackboard:'",
        f"8:7: duplicate node name 'pause' among siblings (first at {path}:7:7)",
    ]
    _both(tmp_path, capsys, DUPLICATE, expected)


def test_a_leading_zero_anywhere_is_said_once_and_only_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Wherever it is (a name, a type, a key, a ref, a list item, an option), the number
    # is the one problem there: nothing that depends on it is checked, and the other
    # problem of the file (the last wait) is reported.
    text = """\
name: 007
root:
  type: sequence
  memory: 01
  children:
    - {type: wait, name: 02, duration: 1 s}
    - {type: 03}
    - {type: success, 04: x}
    - {type: subtree, ref: 05}
    - 06
    - {type: scripted, statuses: [success, 07]}
    - {type: wait, duration: 2 mm}
"""
    path, lines = _validate(tmp_path, capsys, text, "--kind", "tree")
    places = [line.removeprefix(f"{path}:").split(": ", 1)[0] for line in lines]
    assert places == ["1:7", "4:11", "6:26", "7:14", "8:23", "9:28", "10:7", "11:44", "12:20"]
    assert all("has a leading zero" in line for line in lines[:-1])
    assert lines[-1] == f"{path}:12:20: {WAIT_2_MM}"
    assert [f"{path}:{problem}" for problem in _load(path)] == lines


def test_a_misspelt_value_given_is_said_before_the_parameter_it_leaves_out(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # one problem, said at the caller's misspelling, which is why 'distance' is missing
    # (sorted by file, the tree's first, the missing one came first and hid the cause;
    # then both were said, in two lines)
    from pirate_bt.cli import main

    assert main(["run", "straight", "--sim", "straight", "--param", "distanse=1 m"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("pirate-bt: --param distanse=1 m: unknown parameter 'distanse'")
    assert lines[0].endswith("; did you mean 'distance'?")
    # a name close to no parameter that is owed keeps both problems
    assert main(["run", "straight", "--sim", "straight", "--param", "speed=1 m/s"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 2 and "did you mean" not in lines[0], lines
    assert lines[1].endswith("parameter 'distance' has no default and was not given")

"""Tree parameters: examples for checking and drawing, choices checked at load time."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.treefile import load_tree

TREE = """\
name: go
params:
  way: {type: string, choices: [left, right, straight], example: left}
  span: {type: length, example: 1 m}
root:
  type: sequence
  name: go
  children:
    - {type: set_blackboard, name: note way, key: way, value: $way}
blackboard:
  way: {type: string}
"""


@pytest.fixture
def tree_file(tmp_path: Path) -> Path:
    path = tmp_path / "go.yaml"
    path.write_text(TREE)
    return path


def test_examples_are_used_to_check_but_never_to_run(tree_file: Path) -> None:
    checked = load_tree(tree_file, use_examples=True)
    assert checked.params["way"] == "left"
    with pytest.raises(ValidationFailed, match="parameter 'way' has no default and was not given"):
        load_tree(tree_file)


def test_choices_are_checked_at_load_time(tree_file: Path) -> None:
    loaded = load_tree(tree_file, params={"way": "right", "span": "2 m"}, params_from_text=True)
    assert loaded.params["way"] == "right"
    with pytest.raises(ValidationFailed, match="expected one of left, right, straight, got 'up'"):
        load_tree(tree_file, params={"way": "up", "span": "2 m"}, params_from_text=True)


def test_bad_declarations_are_located(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(
        TREE.replace("example: left}", "example: sideways}").replace(
            "span: {type: length,", "span: {type: length, choices: [a],"
        )
    )
    with pytest.raises(ValidationFailed) as info:
        load_tree(path, use_examples=True)
    text = str(info.value)
    assert f"{path}:3:" in text and "example: expected one of left, right, straight" in text
    assert f"{path}:4:" in text and "only a string parameter has choices" in text


def test_validate_and_render_take_params(
    tree_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", str(tree_file)]) == 0
    assert main(["validate", "--param", "way=straight", str(tree_file)]) == 0
    assert main(["validate", "--param", "way=up", str(tree_file)]) == 2
    assert "expected one of left, right, straight" in capsys.readouterr().err
    repo = Path(__file__).resolve().parent.parent
    assert main(["validate", "--param", "way=up", str(repo / "hardware/pirate.yaml")]) == 2
    assert "--param applies to behaviour trees" in capsys.readouterr().err
    out = tmp_path / "go.dot"
    assert main(["render", str(tree_file), "--param", "way=right", "-o", str(out)]) == 0
    assert "note way" in out.read_text()


def test_a_bad_value_is_one_error_not_two(
    tree_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", "--param", "way=up", str(tree_file)]) == 2
    err = capsys.readouterr().err
    assert "expected one of left, right, straight" in err
    assert "was not given" not in err


def test_every_shipped_tree_validates_without_parameters(
    capsys: pytest.CaptureFixture[str],
) -> None:
    repo = Path(__file__).resolve().parent.parent
    trees = sorted((repo / "trees").rglob("*.yaml"))
    assert len(trees) >= 10
    assert main(["validate", "-q", *map(str, trees)]) == 0, capsys.readouterr().err

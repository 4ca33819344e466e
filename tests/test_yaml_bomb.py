"""A YAML alias bomb ("billion laughs") is refused by every YAML file kind, fast and located."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.pipes.loader import load_network
from pirate_bt.robot.loader import load_robot
from pirate_bt.treefile.loader import load_tree
from pirate_bt.yamlfile import MAX_NODES, load_yaml_text


def _bomb(levels: int = 9, width: int = 9, head: str = "") -> str:
    """Nine levels of nine aliases: 9**9 (~387 million) strings once expanded."""
    lines = [head] if head else []
    lines.append(f"l0: &l0 [{', '.join(['lol'] * width)}]")
    for level in range(1, levels):
        refs = ", ".join([f"*l{level - 1}"] * width)
        lines.append(f"l{level}: &l{level} [{refs}]")
    return "\n".join(lines) + "\n"


# Each kind's own top-level key first, so detection by keys picks the kind.
KINDS: dict[str, tuple[str, Callable[[Path], Any]]] = {
    "hardware": ("boards: *l8", load_robot),
    "network": ("segments: *l8", load_network),
    "tree": ("root: *l8", load_tree),
}


def _write(tmp_path: Path, kind: str) -> Path:
    key_line = KINDS[kind][0]
    path = tmp_path / f"{kind}-bomb.yaml"
    path.write_text(_bomb() + key_line + "\n")
    return path


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_yaml_kind_refuses_the_bomb_in_bounded_memory(tmp_path: Path, kind: str) -> None:
    path = _write(tmp_path, kind)
    loader = KINDS[kind][1]
    tracemalloc.start()
    try:
        with pytest.raises(ValidationFailed) as info:
            loader(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    (error,) = info.value.errors
    assert "alias" in str(error)
    assert error.location.file == str(path)
    # Located at a real list of the file (the one that crosses the limit), not at 1:1.
    assert error.location.line > 1
    assert peak < 20_000_000, f"refusing the bomb took {peak} bytes"


@pytest.mark.parametrize("detect", [True, False])
@pytest.mark.parametrize("kind", sorted(KINDS))
def test_validate_cli_refuses_the_bomb_with_exit_2(
    tmp_path: Path, kind: str, detect: bool, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _write(tmp_path, kind)
    args = ["validate", str(path)] if detect else ["validate", "--kind", kind, str(path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"{path}:" in err and "alias" in err
    assert "Traceback" not in err


def test_a_subtree_bomb_is_refused_where_the_subtree_is_loaded(tmp_path: Path) -> None:
    (tmp_path / "sub.yaml").write_text(_bomb() + "root: *l8\n")
    main_tree = tmp_path / "main.yaml"
    main_tree.write_text("root: {type: subtree, name: sub, ref: sub.yaml}\n")
    with pytest.raises(ValidationFailed) as info:
        load_tree(main_tree)
    assert any("alias" in str(e) for e in info.value.errors)


def test_the_limit_counts_expanded_values_not_aliases() -> None:
    # Ordinary anchors (shared motor settings, as hardware/pirate.yaml has) load.
    doc = load_yaml_text("a: &a {x: 1, y: [1, 2]}\nb: [*a, *a, *a]\n")
    assert doc.data["b"][2] == {"x": 1, "y": [1, 2]}
    # Just under the limit loads; one level more is refused.
    width = 300
    row = ", ".join(["1"] * width)
    refs = ", ".join(["*a"] * (MAX_NODES // (width + 1) - 2))
    small = f"a: &a [{row}]\nb: [{refs}]\n"
    assert len(load_yaml_text(small).data["b"]) > 0
    big = (
        f"a: &a [{', '.join(['1'] * width)}]\nb: [{', '.join(['*a'] * (MAX_NODES // width + 1))}]\n"
    )
    with pytest.raises(ValidationFailed) as info:
        load_yaml_text(big, "big.yaml")
    (error,) = info.value.errors
    assert (error.location.line, error.location.column) == (2, 4)

"""Probe 8 (hostile trees): a subtree's ``ref`` naming a file that cannot be read.

``ref: "a\\0b.yaml"`` (a NUL written as an escape in a quoted string) made
``pirate-bt validate`` and ``run`` exit 1 with *internal error: ValueError: embedded
null byte*, and a ref to a loop of symbolic links with *RuntimeError: Symlink loop*;
a file name longer than the system allows was reported without the place of the
``ref``; a folder or a device was "not found".
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("ref", "message"),
    [
        ('"a\\0b.yaml"', r"subtree file 'a\x00b.yaml' cannot be read: a NUL in the file name"),
        ("a" * 300 + ".yaml", "cannot be read: File name too long"),
        ("folder.yaml", "subtree file 'folder.yaml' is a directory, not a file"),
        ("device.yaml", "subtree file 'device.yaml' is not a regular file"),
        ("missing.yaml", "subtree file 'missing.yaml' not found"),
        ("loop.yaml", "subtree file 'loop.yaml' cannot be read: a loop of symbolic links"),
    ],
)
@pytest.mark.parametrize("verb", ["validate", "run"])
def test_an_unreadable_subtree_file_is_one_line_at_its_ref(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    ref: str,
    message: str,
    verb: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder.yaml").mkdir()
    (tmp_path / "loop.yaml").symlink_to("again.yaml")  # Path.resolve raised RuntimeError
    (tmp_path / "again.yaml").symlink_to("loop.yaml")
    if os.path.exists("/dev/null"):
        (tmp_path / "device.yaml").symlink_to("/dev/null")
    Path("tree.yaml").write_text(
        f"root:\n  type: sequence\n  children:\n    - {{type: subtree, ref: {ref}}}\n",
        encoding="utf-8",
    )
    if ref == "device.yaml" and not os.path.exists("/dev/null"):
        pytest.skip("needs /dev/null")
    args = [verb, "tree.yaml"] + (["--quiet"] if verb == "run" else [])
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "tree.yaml:4:23: " in err
    assert message in err

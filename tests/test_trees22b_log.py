"""Session 22 (R2): a ``log`` node's message (docs/trees.md).

A 13 MB message took seconds and hundreds of MB to validate: it was escaped one
character at a time. A message is now at most ``LOG_MESSAGE_MAX`` characters, a longer
one refused at its place in one line, and the escaping is one pass over the text.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt import load_tree
from pirate_bt.behaviours.basic import LOG_MESSAGE_MAX
from pirate_bt.cli import main


def _tree(tmp_path: Path, message: str) -> Path:
    path = tmp_path / "m.yaml"
    path.write_text(f"name: t\nroot: {{type: log, message: '{message}'}}\n", encoding="utf-8")
    return path


def test_a_log_message_longer_than_the_cap_is_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _tree(tmp_path, "x" * (LOG_MESSAGE_MAX + 1))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"{path}:2:19: log: message: must be at most {LOG_MESSAGE_MAX} characters" in err


def test_a_log_message_at_the_cap_is_taken_its_control_characters_escaped(
    tmp_path: Path,
) -> None:
    body = "a\tb\x1b[2J\r\x85" + "x" * (LOG_MESSAGE_MAX - 9)
    path = tmp_path / "m.yaml"
    path.write_text(
        'name: t\nroot: {type: log, message: "a\\tb\\e[2J\\r\\N'
        + "x" * (LOG_MESSAGE_MAX - 9)
        + '"}\n',
        encoding="utf-8",
    )
    assert len(body) == LOG_MESSAGE_MAX
    loaded = load_tree(path)
    assert loaded.root.message == "a\tb\\x1b[2J\\r\\x85" + "x" * (LOG_MESSAGE_MAX - 9)

"""``pirate-bt sim``'s options: one that the chosen simulator cannot honour is refused,
never dropped without a word."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize("option", ["--foxglove", "--ros2"])
def test_a_live_view_with_the_firmware_is_refused_not_dropped(
    option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: ``sim --firmware piratebay.elf --foxglove`` (or ``--ros2``) served the
    firmware on its pty with no live view at all, and said nothing of it, exit 0."""
    elf = tmp_path / "piratebay.elf"  # refused before the firmware is read
    elf.write_bytes(b"")
    assert main(["sim", "--firmware", str(elf), "--duration", "1", option]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # no pty served
    assert captured.err.splitlines() == [
        f"pirate-bt: {option} is not served with --firmware (it shows the Python simulator);"
        " drop one of them"
    ]

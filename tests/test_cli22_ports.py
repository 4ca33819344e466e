"""The command line's ``--port``: a real robot's serial port or URL, refused as the
user typed it, before anything connects, on every verb that takes it."""

from __future__ import annotations

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize("port", ["bogus", "sim:lab"])
def test_teleop_s_port_is_a_real_robot_s_named_as_typed(
    port: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: ``teleop --port bogus`` said the API's "connect: 'bogus' is neither a
    network (write sim:NAME or a .yaml file) nor a serial port", an option nobody typed,
    and ``teleop --port sim:lab`` drove a simulator (exit 0), where run, mission, survey
    and navigate refuse it."""
    assert main(["teleop", "--keys", "q", "--port", port]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # no console drawn: nothing connected
    assert captured.err.splitlines() == [
        f"pirate-bt: --port: {port!r} is not a serial port or pyserial URL (/dev/ttyACM0,"
        " COM3, socket://HOST:PORT)"
    ]

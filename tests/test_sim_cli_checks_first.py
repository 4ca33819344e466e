"""``pirate-bt sim`` checks its network's faults before it opens a live view.

A network file whose fault names a motor the robot lacks was refused only after the
Foxglove server had been opened and announced (*Foxglove live view on ws://...*),
and the server was left open.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

pytest.importorskip("foxglove")


def test_a_bad_network_fault_is_refused_before_the_live_view_opens(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    net = tmp_path / "badf.yaml"
    net.write_text(
        "schema_version: 1\nname: badf\ndiameter: 63 mm\n"
        "segments:\n  - {type: straight, length: 2 m}\n"
        "faults:\n  - {kind: motor_stall, target: nope, at: 1 s}\n",
        encoding="utf-8",
    )
    assert main(["sim", str(net), "--foxglove", "0"]) == 2
    err = capsys.readouterr().err
    assert "live view" not in err, err
    assert err.startswith(f"pirate-bt: {net}:7:25: faults: fault motor_stall: unknown motor")

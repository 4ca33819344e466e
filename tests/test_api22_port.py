"""Session 22: a robot's port given as a path (Path("/dev/ttyACM0")) is that device,
at run_tree, run_mission and navigate alike (docs/api.md, Arguments the API refuses)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.errors import LinkError

DEVICE = Path("/dev/pirate-bt-no-such-device")


@pytest.mark.parametrize(
    "call",
    [
        lambda: pirate_bt.run_tree("straight", port=DEVICE, params={"distance": "0.1 m"}),
        lambda: pirate_bt.run_mission("bend-right", port=DEVICE),
        lambda: pirate_bt.navigate("explore", port=DEVICE),
    ],
    ids=["run_tree", "run_mission", "navigate"],
)
def test_a_port_given_as_a_path_is_opened_as_that_device(call: Any) -> None:
    # was refused before opening: "port: PosixPath('/dev/ttyACM0') is not a serial port
    # or pyserial URL (/dev/ttyACM0, COM3, socket://HOST:PORT)"; navigate took it on to
    # connect(), which reads a Path as a network file for the simulator
    with pytest.raises(LinkError) as caught:
        call()
    assert str(caught.value).startswith(f"cannot open {DEVICE}")


def test_a_network_file_given_as_a_port_is_still_refused() -> None:
    with pytest.raises(
        pirate_bt.InputError, match=r"^port: 'scenarios/straight.yaml' is not a serial port"
    ):
        pirate_bt.run_tree("straight", port=Path("scenarios/straight.yaml"))


def test_connect_to_a_device_given_as_a_path_opens_that_port() -> None:
    # was read as a network file: "network: no network '/dev/...'; bundled networks: ..."
    with pytest.raises(LinkError) as caught:
        pirate_bt.connect(DEVICE)
    assert str(caught.value).startswith(f"cannot open {DEVICE}")
    with pirate_bt.connect(Path("scenarios/straight.yaml")) as robot:  # a network file
        assert robot.simulator is not None

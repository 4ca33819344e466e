"""``connect(..., firmware=True)``, ``"firmware:NETWORK"`` and ``--firmware-chain``: the
simulator's physics behind the real firmwares, from the public door.

The runs themselves (a PAB through the whole chain) are in test_firmware_chain.py,
where simavr is needed; these are the door's own rules, which need nothing built.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.api.options import parse_target
from pirate_bt.errors import ConfigurationError, InputError


def test_a_firmware_target_names_its_network() -> None:
    assert parse_target("firmware:bend-right") == ("firmware", "bend-right")
    assert parse_target("firmware") == ("firmware", "straight")
    assert parse_target("firmware:") == ("firmware", "straight")
    # written as a URL, the same targets
    assert parse_target("firmware://bend-right") == ("firmware", "bend-right")
    assert parse_target("sim://lab") == ("sim", "lab")
    assert parse_target("sim://") == ("sim", "straight")


def test_firmware_is_refused_for_a_real_port() -> None:
    with pytest.raises(InputError, match="a port"):
        pirate_bt.connect("/dev/ttyACM0", firmware=True)


def test_simulator_faults_are_refused_through_the_firmware() -> None:
    with pytest.raises(InputError, match="link faults"):
        pirate_bt.connect("firmware:straight", faults="motor_stall:bend_3_drive@5s")


def test_a_missing_firmware_build_says_how_to_build_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    missing = tmp_path / "piratebay.elf"
    monkeypatch.setenv("PIRATE_BRIDGE_ELF", str(missing))
    with pytest.raises(ConfigurationError, match="make firmware") as caught:
        pirate_bt.simulate_tree(
            "straight", network="straight", params={"distance": "1 m"}, firmware=True
        )
    assert str(missing) in str(caught.value)


def test_an_unknown_network_is_named_before_anything_starts() -> None:
    with pytest.raises(InputError, match="no-such-network"):
        pirate_bt.connect("firmware:no-such-network")


@pytest.mark.parametrize(
    "verb",
    [
        pytest.param(["run", "trees/straight.yaml", "--param", "distance=1m"], id="run"),
        pytest.param(["mission", "scenarios/lab.route"], id="mission"),
    ],
)
def test_the_command_line_refuses_the_chain_with_a_port(verb: list[str]) -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pirate_bt",
            *verb,
            "--port",
            "/dev/null",
            "--firmware-chain",
            "--foxglove",
            "127.0.0.1:0",
        ],
        capture_output=True,
        text=True,
        cwd=Path(__file__).resolve().parents[1],
        check=False,
    )
    assert done.returncode == 2
    assert "--firmware-chain" in done.stderr and "--port" in done.stderr
    # refused before anything opened: no live view was started (and left running)
    assert "Foxglove" not in done.stderr

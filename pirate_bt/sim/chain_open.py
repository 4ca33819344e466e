"""Open the whole embedded chain for a robot in a network (``connect(..., firmware=True)``).

:class:`~pirate_bt.sim.chain.FirmwareChain` needs three built files: the bridge ELF
(``firmware/piratebay``), the PICO ELF (``firmware/pico``) and the ``pirate-chain``
harness (``firmware/simavr``). :func:`open_firmware_chain` finds them (an argument,
an environment variable, or the repository's build, in that order), builds the pipe
physics for the network and starts the chain on the given simulated clock.
:class:`ChainSimulator` shows the chain to a connection as its simulator: the
physics' ground truth and counters, which results and traces read, and the chain's
own figures.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Literal

from pirate_bt.clock import SimClock
from pirate_bt.errors import ConfigurationError
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.chain import FirmwareChain
from pirate_bt.sim.counters import SimCounters
from pirate_bt.sim.model import PipeRobotModel
from pirate_bt.sim.model_types import SimTruth

__all__ = [
    "BRIDGE_ELF_ENV",
    "PICO_ELF_ENV",
    "ChainSimulator",
    "find_firmware_elf",
    "open_firmware_chain",
]

BRIDGE_ELF_ENV = "PIRATE_BRIDGE_ELF"
"""Environment variable naming the bridge ELF (default: the repository's build)."""
PICO_ELF_ENV = "PIRATE_PICO_ELF"
"""Environment variable naming the PICO board ELF (default: the repository's build)."""

_REPO = Path(__file__).resolve().parents[2]
_DEFAULT = {
    "bridge": (BRIDGE_ELF_ENV, _REPO / "firmware" / "piratebay" / "build" / "piratebay.elf"),
    "pico": (PICO_ELF_ENV, _REPO / "firmware" / "pico" / "build" / "pico.elf"),
}


def find_firmware_elf(
    which: Literal["bridge", "pico"], path: str | os.PathLike[str] | None = None
) -> Path:
    """The ELF of the bridge or of the PICO board: ``path``, its variable, or the build.

    Raises:
        ConfigurationError: the file is not there (with the command that builds it).
    """
    env, default = _DEFAULT[which]
    chosen = path or os.environ.get(env)
    candidate = Path(chosen) if chosen else default
    if not candidate.is_file():
        raise ConfigurationError(
            f"the {which} firmware is not built ({candidate} missing): run `make firmware`"
            f" (or set {env})"
        )
    return candidate


class ChainSimulator:
    """The chain as a connection's simulator: the physics' truth and counters.

    The frame counters of :class:`~pirate_bt.sim.counters.SimCounters` are those of
    the Python bridge, which the chain does not have: they stay 0; the bridge
    firmware's own are in :meth:`figures`.

    Attributes:
        chain: The running chain.
        model: The pipe physics behind the PICO boards' pins.
    """

    def __init__(self, chain: FirmwareChain) -> None:
        self.chain = chain
        self.model: PipeRobotModel = chain.physics.model

    def counters(self) -> SimCounters:
        """Violations, damage, stuck events and distance so far (the physics')."""
        return self.model.counters()

    def truth(self) -> SimTruth:
        """Ground truth now: positions, segments, rolls, clamps, joint angles."""
        return self.model.truth()

    def figures(self) -> dict[str, Any]:
        """The chain's figures: the line, the bus cycle, stacks, every board's counters."""
        return dict(self.chain.figures())

    def close(self) -> None:
        """Stop the chain (idempotent)."""
        self.chain.close()


def open_firmware_chain(
    robot: RobotDescription,
    network: Any,
    *,
    clock: SimClock,
    bridge_elf: str | os.PathLike[str] | None = None,
    pico_elf: str | os.PathLike[str] | None = None,
) -> FirmwareChain:
    """Start the bridge and one PICO per board in simavr, with ``network``'s physics.

    Args:
        robot: The robot description (the firmwares are built for its wire layout;
            another layout is refused at the handshake).
        network: A ``Network``.
        clock: The simulated clock the chain steps with.
        bridge_elf: The bridge ELF (default: ``$PIRATE_BRIDGE_ELF`` or the build).
        pico_elf: The PICO ELF (default: ``$PIRATE_PICO_ELF`` or the build).

    Raises:
        ConfigurationError: a firmware or the harness is not built.
        LinkError: the harness did not start.
    """
    bridge = find_firmware_elf("bridge", bridge_elf)
    pico = find_firmware_elf("pico", pico_elf)
    return FirmwareChain(bridge, pico, PipeRobotModel(robot, network), clock=clock)

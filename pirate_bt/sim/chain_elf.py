"""Which robot description a firmware ELF was built for, read from the ELF itself.

Both firmwares (``firmware/piratebay``, ``firmware/pico``) keep the layout digest of
the description they were built for under the symbol ``pb_layout_digest``
(``robot_layout.c``), in a section of the ELF that is not loaded: the chip never gets
it, and the HEX and the sizes are those of a build without it. A simulator that puts
an ELF behind boards of one description reads it here and refuses an ELF built for
another, in one line, before anything runs:
``pirate-bt sim --firmware`` (:class:`~pirate_bt.sim.firmware_bridge.FirmwareBridge`)
and the whole chain (:class:`~pirate_bt.sim.chain.FirmwareChain`). Until 2026-11-30 the
bridge built for ``hardware/variants/pirate-long.yaml`` ran behind the default robot's
boards: boards 29 and 30 never answered, and a host with the right description was told
*the bridge reports its e-stop latched* (the boot latch could not be released).

Only what that needs of ELF32 (little-endian, as avr-gcc writes it): the section
headers, the symbol table and the bytes of one symbol.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

from pirate_bt.errors import InputError
from pirate_bt.robot.description import RobotDescription

__all__ = ["CPR_SYMBOL", "DIGEST_SYMBOL", "check_built_for", "elf_layout_digest", "elf_u32"]

DIGEST_SYMBOL = "pb_layout_digest"
CPR_SYMBOL = "pico_encoder_cpr"
"""The PICO's ``ENCODER_CPR`` (encoder counts per wheel revolution), as it was built."""
_SHT_SYMTAB = 2


def elf_layout_digest(path: str | os.PathLike[str]) -> int | None:
    """The layout digest ``path`` was built for; ``None`` when it does not say.

    An ELF built before the symbol existed, or a file that is no ELF32 (the
    harnesses refuse those themselves, naming what they are), says nothing.
    """
    return elf_u32(path, DIGEST_SYMBOL)


def elf_u32(path: str | os.PathLike[str], symbol: str) -> int | None:
    """The 4-byte little-endian value of ``symbol`` in the ELF ``path``, or ``None``."""
    try:
        data = Path(path).read_bytes()
    except OSError:
        return None
    try:
        return _symbol_u32(data, symbol)
    except (struct.error, IndexError, ValueError):
        return None


def _symbol_u32(data: bytes, symbol: str) -> int | None:
    if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:  # ELF32, little-endian
        return None
    shoff, _, _, _, _, shentsize, shnum, _ = struct.unpack_from("<IIHHHHHH", data, 32)
    sections = [
        struct.unpack_from("<IIIIIIIIII", data, shoff + i * shentsize) for i in range(shnum)
    ]
    for _name, kind, _flags, _addr, offset, size, link, _info, _align, entsize in sections:
        if kind != _SHT_SYMTAB or entsize < 16:
            continue
        strings = sections[link]
        for at in range(offset, offset + size, entsize):
            name_at, value, sym_size, _, _, shndx = struct.unpack_from("<IIIBBH", data, at)
            end = data.index(b"\0", strings[4] + name_at)
            if data[strings[4] + name_at : end] != symbol.encode() or sym_size != 4:
                continue
            _, _, _, addr, at_file, in_file, *_ = sections[shndx]
            if not addr <= value <= addr + in_file - 4:
                return None
            start = at_file + value - addr  # the file offset of the symbol's bytes
            return int.from_bytes(data[start : start + 4], "little")
    return None


def check_built_for(path: str | os.PathLike[str], robot: RobotDescription) -> None:
    """Refuse an ELF built for another robot description than ``robot``.

    Args:
        path: The firmware ELF.
        robot: The description of the boards it would run behind.

    Raises:
        InputError: it says it was built for another description.
    """
    built = elf_layout_digest(path)
    want = robot.layout_digest()
    if built is None or built == want:
        return
    raise InputError(
        f"{path} was built for another robot description (its layout digest 0x{built:08x};"
        f" the simulator's robot {robot.name!r} has 0x{want:08x}): give the simulator the"
        " description it was built for (--robot), or rebuild it (make firmware ROBOT=...)"
    )

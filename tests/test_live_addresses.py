"""``--groot2`` and ``--foxglove`` read HOST:PORT alike, and refuse what a typo makes
of it instead of taking it for a host name."""

from __future__ import annotations

import pytest

from pirate_bt.errors import InputError
from pirate_bt.interop.foxglove_option import parse_address
from pirate_bt.interop.groot2_option import parse_groot2_address


@pytest.mark.parametrize(
    ("text", "groot2", "foxglove"),
    [
        (None, ("127.0.0.1", 1667), ("127.0.0.1", 8765)),
        ("1700", ("127.0.0.1", 1700), ("127.0.0.1", 1700)),
        (":1700", ("127.0.0.1", 1700), ("127.0.0.1", 1700)),
        ("robot", ("robot", 1667), ("robot", 8765)),
        ("robot:1700", ("robot", 1700), ("robot", 1700)),
        ("[::1]:1700", ("::1", 1700), ("::1", 1700)),
        ("[::1]", ("::1", 1667), ("::1", 8765)),
    ],
)
def test_both_options_read_an_address_alike(
    text: str | None, groot2: tuple[str, int], foxglove: tuple[str, int]
) -> None:
    assert parse_groot2_address(text) == groot2
    assert parse_address(text) == foxglove


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("[::1", "write an IPv6 address in brackets, then its port: [::1]:PORT"),
        ("[::1]x", "write an IPv6 address in brackets, then its port: [::1]:PORT"),
        # '::1:1700' is an IPv6 address of its own: port 1700 of ::1 was meant, most
        # likely; it was taken as the host ::1:1700 on the default port (as --ros2 refuses)
        ("::1:1700", "write an IPv6 address in brackets, then its port: [::1]:PORT"),
        ("::1", "write an IPv6 address in brackets, then its port: [::1]:PORT"),
        ("1667:", "the port must be a number from 0 to 65534"),
        ("[::1]:", "the port must be a number from 0 to 65534"),
        ("robot:http", "the port must be a number from 0 to 65534"),
        ("65535", "the port must be a number from 0 to 65534 (the next one is the publisher's)"),
    ],
)
def test_a_typo_is_refused_not_taken_for_a_host(text: str, words: str) -> None:
    with pytest.raises(InputError, match=r"^--groot2 ") as caught:
        parse_groot2_address(text)
    assert words in str(caught.value)
    if text != "65535":  # Foxglove takes 65535: it has no second socket
        with pytest.raises(InputError, match=r"^--foxglove "):
            parse_address(text)

"""The link under faults, probed from the user docs (docs/protocol.md, docs/safety.md).

Each test pins a bug a user saw, fixed here: a malformed ``--port`` URL, bytes no
frame should contain, forged frames with a good CRC.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError, LinkError
from pirate_bt.link.transport import Transport

REPO = Path(__file__).resolve().parent.parent
STRAIGHT = str(REPO / "trees" / "straight.yaml")


@pytest.mark.parametrize(
    ("url", "said"),
    [
        ("socket://host:notaport", "the port 'notaport' is not from 0 to 65535"),
        ("socket://:99999", "the port '99999' is not from 0 to 65535"),
        ("socket://", "no host; give socket://HOST:PORT"),
        ("socket://[::1", "no host and port in '[::1' (Invalid IPv6 URL)"),
        ("socket://127.0.0.1:5760?x=1", "no option 'x' (a socket:// URL takes logging)"),
        ("rfc2217://127.0.0.1:5760?timeout=abc", "timeout='abc' is not a number of seconds"),
    ],
)
def test_a_malformed_port_url_is_bad_input_exit_2(
    url: str, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`pirate-bt run --port socket://host:notaport` exited 3 (link error) for what is
    a bad argument (exit 2, DESIGN.md's command-line contract); `socket://` said
    *'<=' not supported between instances of 'int' and 'NoneType'*, `socket://[::1`
    was an *internal error: ValueError: Invalid IPv6 URL* (exit 1) and `?x=1` said
    *'debug|info|warning|error'*."""
    code = main(["run", STRAIGHT, "--param", "distance=0.1m", "--quiet", "--port", url])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("pirate-bt:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert code == 2, err
    assert lines[0].startswith(f"pirate-bt: cannot open {url}: {said}"), lines[0]


def test_a_malformed_port_url_is_still_a_link_error_to_python() -> None:
    """A caller that catches the failure to connect as a ``LinkError`` still does."""
    with pytest.raises(LinkError) as caught:
        Transport.open("socket://", baud=115200)
    assert isinstance(caught.value, InputError)
    assert caught.value.exit_code == 2

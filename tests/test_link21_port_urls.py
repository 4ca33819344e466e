"""Session 21: a port URL of a scheme no handler has, or one that names nothing after its
scheme, is invalid input (exit 2, one line naming --port and the schemes there are); a
well-formed port that cannot be opened stays a link error (exit 3). docs/protocol.md,
Line."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import InputError, LinkError
from pirate_bt.link.port_urls import url_schemes
from pirate_bt.link.transport import PortURLError, Transport

STRAIGHT = str(Path(__file__).resolve().parent.parent / "trees" / "straight.yaml")
# pyserial's own schemes (cp2110:// too where its hid module is installed)
SCHEMES = ", ".join(f"{s}://" for s in url_schemes())
NO_SCHEME = "here: a port is a device (/dev/ttyACM0, COM3) or a URL of " + SCHEMES


def _run(url: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    code = main(["run", STRAIGHT, "--param", "distance=0.1m", "--quiet", "--port", url])
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return code, [line for line in err.splitlines() if line.startswith("pirate-bt:")]


@pytest.mark.parametrize(
    ("url", "said"),
    [
        ("bogus://x", f"no URL scheme 'bogus' {NO_SCHEME}"),
        ("HTTP://x", f"no URL scheme 'HTTP' {NO_SCHEME}"),
        ("spy://", "nothing after spy://; give spy://DEVICE"),
        ("hwgrep://", "nothing after hwgrep://; give hwgrep://PATTERN"),
        ("alt://?class=Serial", "nothing after alt://; give alt://DEVICE?class=NAME"),
    ],
)  # fmt: skip
def test_a_port_url_of_no_scheme_here_is_bad_input_naming_the_option(
    url: str, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--port bogus://x` exited 3 (a link error) with pyserial's *invalid URL, protocol
    'bogus' not known*; `--port hwgrep://` opened the machine's first serial port."""
    code, lines = _run(url, capsys)
    assert code == 2, lines
    assert lines == [f"pirate-bt: --port: cannot open {url}: {said}"]


def test_the_api_s_port_parameter_is_named_as_the_option_too(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, lines = _run("bogus:x", capsys)
    assert code == 2
    assert lines == [
        "pirate-bt: --port: 'bogus:x' is not a serial port or pyserial URL (/dev/ttyACM0,"
        " COM3, socket://HOST:PORT)"
    ]


def test_a_well_formed_port_that_cannot_be_opened_stays_a_link_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    device = "/dev/pirate-bt-no-such-tty"
    code, lines = _run(device, capsys)
    assert code == 3
    assert len(lines) == 1 and lines[0].startswith(f"pirate-bt: cannot open {device}: ")


def test_the_schemes_named_are_pyserial_s_and_not_the_simulator_s() -> None:
    import pirate_bt.sim  # noqa: F401  (registers sim:// and chain://)

    schemes = set(url_schemes())
    assert {"alt", "hwgrep", "loop", "rfc2217", "socket", "spy"} <= schemes
    assert not schemes & {"sim", "chain"}


def test_connect_refuses_a_port_of_no_scheme_here_as_input() -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.connect("bogus://x")
    assert str(caught.value) == (
        "cannot open bogus://x: no URL scheme 'bogus' here: a port is a device (/dev/ttyACM0,"
        f" COM3) or a URL of {SCHEMES}"
    )
    assert caught.value.exit_code == 2
    assert isinstance(caught.value, LinkError)  # a failure to connect, to a caller that asks


def test_the_refusal_names_its_url_and_crosses_a_process_boundary() -> None:
    with pytest.raises(PortURLError) as caught:
        Transport.open("spy://", baud=115200)
    again = pickle.loads(pickle.dumps(caught.value))
    assert (type(again), str(again), again.port_url) == (
        PortURLError,
        "cannot open spy://: nothing after spy://; give spy://DEVICE",
        "spy://",
    )

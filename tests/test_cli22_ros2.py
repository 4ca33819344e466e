"""The command line's ``--ros2 ENDPOINT``: an endpoint whose host does not resolve is
refused before anything starts, as ``--foxglove`` and ``--groot2`` refuse theirs.

No name server is asked: ``socket.getaddrinfo`` is replaced by one that knows no name
but ``localhost``, so the tests give the same answer on any machine."""

from __future__ import annotations

import socket
from typing import Any

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.interop import ros2_option

_real_getaddrinfo = socket.getaddrinfo


@pytest.fixture
def names(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Every host looked up; only ``localhost`` and addresses resolve."""
    asked: list[str] = []

    def getaddrinfo(host: Any, port: Any, *args: Any, **kwargs: Any) -> Any:
        asked.append(host)
        if host == "localhost" or host.replace(".", "").isdigit() or ":" in host:
            return _real_getaddrinfo(host, port, *args, **kwargs)
        raise socket.gaierror(socket.EAI_NONAME, "Name or service not known")

    monkeypatch.setattr(socket, "getaddrinfo", getaddrinfo)
    return asked


@pytest.mark.parametrize(
    "argv",
    [
        ["sim", "--tcp", "0", "--duration", "1"],
        ["run", "straight", "--param", "distance=0.1m"],
    ],
    ids=["sim", "run"],
)
def test_a_ros2_host_that_does_not_resolve_is_refused_before_anything_starts(
    argv: list[str], names: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: ``pirate-bt sim --ros2 routr.invalid`` served on, and ``run`` ran the tree,
    their node trying for ever to reach a router at a name that does not exist (the graph
    never saw the run, its e-stop topic never reached it), exit 0."""
    pytest.importorskip("zenoh")
    assert main([*argv, "--ros2", "routr.invalid:7447"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # no socket:// served, no run's summary
    assert captured.err.splitlines() == [
        "pirate-bt: --ros2 routr.invalid:7447: unknown host: [Errno -2] Name or service not known"
    ]
    assert "routr.invalid" in names


def test_a_host_that_resolves_or_a_unix_socket_is_taken(names: list[str]) -> None:
    """A router not started yet is no error (the node joins when it starts): only the
    name is checked, and a unix socket has none."""
    ros2_option.check_endpoint_host("localhost:7447")
    ros2_option.check_endpoint_host("tcp/[::1]:7447")
    ros2_option.check_endpoint_host(None)  # the default router, 127.0.0.1
    ros2_option.check_endpoint_host("unixsock-stream/tmp/router.sock")
    assert "localhost" in names
    with pytest.raises(InputError, match=r"^--ros2 tls/routr\.invalid: unknown host: "):
        ros2_option.check_endpoint_host("tls/routr.invalid")


def test_an_endpoint_with_a_control_character_is_one_line(names: list[str]) -> None:
    """Before: ``--ros2 $'a\\nb:99999'`` was two lines, ``--ros2 a`` and ``b:99999: the
    port must be ...``."""
    for text, words in (("a\nb:99999", "the port"), ("a\nb:1", "unknown host")):
        with pytest.raises(InputError) as caught:
            ros2_option.check_endpoint_host(text)
        message = str(caught.value)
        assert "\n" not in message and words in message
        assert message.startswith("--ros2 'a\\nb:")

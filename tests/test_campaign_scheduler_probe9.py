"""A far end that is not a Dask scheduler, and a scheduler file that is not one (probe 9).

Dask's connect bounds the TCP connection but not the handshake after it: a listener
that took the connection and never answered (an HTTP server waiting for its request
line) held ``--scheduler-timeout 3s`` for ever, and one that answered ``HTTP/1.1 400``
at once had its text read as a frame length (``internal error: MemoryError``). A
scheduler file that is not one failed in Dask's client (``AssertionError``,
``TypeError``). Each is now one line and exit 2, within the timeout.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from pirate_bt.cli import main

pytest.importorskip("distributed")

SPEC = """\
name: probe9
runs:
  - {name: s, tree: straight, network: straight, params: {distance: 0.2 m}}
seeds: {start: 0, count: 1}
max_time: 60 s
"""

TIMEOUT_S = 1.0


def _silent(conn: socket.socket) -> None:
    pass  # takes the connection, never answers


def _http_400(conn: socket.socket) -> None:
    conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")


@contextmanager
def _listener(answer: Callable[[socket.socket], None]) -> Iterator[str]:
    """``tcp://127.0.0.1:PORT`` of a socket server in a thread that answers with ``answer``."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    server.settimeout(0.1)
    stop = threading.Event()
    taken: list[socket.socket] = []

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            taken.append(conn)
            answer(conn)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join()
        for conn in taken:
            conn.close()
        server.close()


class _Quiet(SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass  # not on the standard error the test reads


@contextmanager
def _http_server() -> Iterator[str]:
    """An HTTP server in a thread (``python -m http.server``'s)."""
    server = ThreadingHTTPServer(("127.0.0.1", 0), _Quiet)
    server.daemon_threads = True
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


def _spec(tmp_path: Path) -> Path:
    path = tmp_path / "c.campaign.yaml"
    path.write_text(SPEC, encoding="utf-8")
    return path


def _one_error(capsys: pytest.CaptureFixture[str]) -> str:
    captured = capsys.readouterr()
    assert captured.out == ""  # refused before the "campaign NAME: N cases on ..." line
    err = captured.err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err.strip().removeprefix("pirate-bt: ")


def _campaign(tmp_path: Path, *where: str) -> int:
    out = tmp_path / "out"
    args = ["campaign", str(_spec(tmp_path)), "--output", str(out), "--quiet", *where]
    return main([*args, "--scheduler-timeout", f"{TIMEOUT_S:g} s"])


@pytest.mark.parametrize(
    ("far_end", "what"),
    [
        (lambda: _listener(_silent), ("did not answer Dask's handshake within 1 s",)),
        # it answers Dask's first frame with a 400 it may not finish: either is fine
        (_http_server, ("did not answer Dask's handshake within 1 s", "not Dask's protocol")),
        (lambda: _listener(_http_400), ("its reply is not Dask's protocol (MemoryError",)),
    ],
    ids=["silent", "http-server", "http-400"],
)
def test_a_far_end_that_is_not_a_scheduler_is_one_line_within_the_timeout(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    far_end: Callable[[], AbstractContextManager[str]],
    what: tuple[str, ...],
) -> None:
    with far_end() as address:
        before = set(threading.enumerate())
        start = time.monotonic()
        code = _campaign(tmp_path, "--scheduler", address)
        took = time.monotonic() - start
        # the fake HTTP server's own request threads (it answers on its own) are not ours
        left = [
            t
            for t in set(threading.enumerate()) - before
            if t.is_alive() and "process_request_thread" not in t.name
        ]
    assert code == 2
    line = _one_error(capsys)
    assert line.startswith(f"no Dask scheduler answered at {address}: "), line
    assert any(w in line for w in what), line
    assert took < TIMEOUT_S + 5, took
    assert left == []  # no client, loop or check thread left running
    assert not (tmp_path / "out" / "results.jsonl").exists()


def test_a_scheduler_file_naming_a_far_end_that_is_not_a_scheduler(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with _listener(_silent) as address:
        file = tmp_path / "scheduler.json"
        file.write_text(f'{{"address": "{address}"}}', encoding="utf-8")
        start = time.monotonic()
        assert _campaign(tmp_path, "--scheduler-file", str(file)) == 2
        assert time.monotonic() - start < TIMEOUT_S + 5
    assert _one_error(capsys).startswith(f"no Dask scheduler answered at {address}: ")


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("{}", 'no "address" in it'),
        ("not json", "not JSON: "),
        ("address: tcp://127.0.0.1:8786\n", "not JSON: "),  # YAML
        ('{"address": 5}', 'its "address" is 5, not an address like tcp://host:8786'),
        ('["tcp://127.0.0.1:8786"]', "JSON list, not an object with an address"),
    ],
    ids=["empty-object", "not-json", "yaml", "address-not-a-string", "a-list"],
)
def test_a_file_that_is_not_a_scheduler_file_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, why: str
) -> None:
    file = tmp_path / "scheduler.json"
    file.write_text(text, encoding="utf-8")
    assert _campaign(tmp_path, "--scheduler-file", str(file)) == 2
    line = _one_error(capsys)
    assert line.startswith(f"--scheduler-file {file}: not a Dask scheduler file ("), line
    assert why in line and line.endswith(")"), line

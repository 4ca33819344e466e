"""The case server: ``python -m pirate_bt.campaign.child``, started once per executor worker.

A campaign's cases run in processes forked from a **case server** (a fork
server): :mod:`pirate_bt.campaign.workers` starts one per worker of the
executor (a process of the local pool, a thread of a Dask worker) and keeps it
for every case that worker runs. The server imports what cases use once
(:data:`pirate_bt.campaign.case.PRELOAD`, with ``PYTHONHASHSEED=0`` in its
environment) and builds what every run builds alike
(:func:`pirate_bt.campaign.case.prepare`: the node registry), moves those
objects out of the garbage collector's reach (``gc.freeze``, so forks share
their pages), then serves one case at a time:

1. it reads a request line on standard input;
2. it imports the request's extra modules (``preload``, and the target's
   module) if it has not yet: in itself, never in a case;
3. it forks a **case process**, which starts a session of its own (its pid is
   its process group), calls the target, writes the record to a pipe and
   exits; its standard output and error go to a second pipe, of which the
   server keeps the last :data:`STDERR_TAIL` bytes;
4. when the case process has exited, the server kills whatever is left of its
   process group and replies with the exit status, the record and the tail.

Every case therefore starts from the same freshly imported state and nothing a
case does (its blackboard, logging handlers, registries, memory, a crash) lives
on after it. The server never runs a case itself, so only a broken import or a
signal sent to it can end it; the worker then starts another.

The protocol, one JSON object per line each way:

- request ``{"target": "module:function", "case": {...}, "trace_dir": str|null,
  "preload": [module, ...]}``;
- reply ``{"started": PID}`` once the case process is forked;
- reply ``{"ended": PID, "status": S, "record": TEXT|null, "stderr": TAIL}`` when it
  has ended: ``S`` is its exit code (negative: killed by that signal),
  ``TEXT`` the record's JSON text.

The worker enforces the case's wall-time limit itself: it kills the case
process's group (``os.killpg(PID, SIGKILL)``), and the server replies as for any
other end. The server exits when its standard input closes, killing a case still
running first. On Linux it also ends with its worker (``--parent PID``:
``PR_SET_PDEATHSIG``, :func:`die_with_parent`): a ``SIGTERM``, however it comes,
kills the running case's group and then the server.
"""

from __future__ import annotations

import contextlib
import ctypes
import gc
import importlib
import json
import os
import selectors
import signal
import sys
import time
import traceback
from typing import Any, NoReturn

__all__ = ["STDERR_TAIL", "Lines", "die_with_parent", "main", "send", "serve"]

STDERR_TAIL = 16_384
"""How many of the last bytes of a case process's output the server keeps."""

_DRAIN_S = 2.0
"""How long the server reads a case's pipes after the case process has exited."""


_PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int, parent: int | None) -> None:
    """Have the kernel send ``sig`` to this process when its parent dies (Linux only).

    ``PR_SET_PDEATHSIG``: a pool worker, or a case server, left behind by a killed
    campaign was re-parented to PID 1 and ran on for ever. The setting is the
    parent *thread*'s: the pool's workers and the servers are started by threads
    that live as long as they are used (the pool worker's main thread, a Dask
    worker's). If the parent is no longer ``parent`` once it is set (it died
    before), ``sig`` is sent at once. Elsewhere than on Linux, or if ``prctl``
    fails, nothing is set.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        zero = ctypes.c_ulong(0)
        code = libc.prctl(_PR_SET_PDEATHSIG, ctypes.c_ulong(sig), zero, zero, zero)
    except (OSError, AttributeError):
        return
    if code == 0 and parent is not None and os.getppid() != parent:
        os.kill(os.getpid(), sig)


class Lines:
    """JSON lines read from a file descriptor, with a deadline."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.buffer = bytearray()
        self.closed = False
        self._selector = selectors.DefaultSelector()
        self._selector.register(fd, selectors.EVENT_READ)

    def pending(self) -> bool:
        """Whether a whole line is waiting in the buffer."""
        return b"\n" in self.buffer

    def fill(self) -> bool:
        """Read what is there (the descriptor is readable); ``False`` at end of file."""
        chunk = os.read(self.fd, 1 << 16)
        if not chunk:
            self.closed = True
            return False
        self.buffer += chunk
        return True

    def read(self, deadline: float | None = None) -> dict[str, Any] | None:
        """The next line's object; ``None`` if none came by ``deadline`` (``time.monotonic``).

        Raises:
            EOFError: The other end closed before a whole line came.
        """
        while not self.pending():
            if self.closed:
                raise EOFError
            timeout = None if deadline is None else max(0.0, deadline - time.monotonic())
            if not self._selector.select(timeout):
                return None
            if not self.fill():
                raise EOFError
        end = self.buffer.index(b"\n")
        line = bytes(self.buffer[:end])
        del self.buffer[: end + 1]
        value = json.loads(line)
        if not isinstance(value, dict):
            raise ValueError(f"not a message: {line[:80]!r}")
        return value

    def close(self) -> None:
        self._selector.close()


def send(fd: int, message: dict[str, Any]) -> None:
    """Write one message as one line (all of it, however the pipe takes it)."""
    data = memoryview((json.dumps(message, allow_nan=False) + "\n").encode())
    while data:
        data = data[os.write(fd, data) :]


def _import(names: list[str]) -> None:
    for name in names:
        if name and name not in sys.modules:
            # A module that fails here fails again in the case process, which reports it.
            with contextlib.suppress(Exception):
                importlib.import_module(name)


def _case_process(
    request: dict[str, Any], result_w: int, output_w: int, mask: set[int | signal.Signals]
) -> NoReturn:
    """The forked case process: run the target, write the record, exit. Never returns."""
    code = 1
    try:
        # What a fresh process has, not the server's SIGTERM handler and blocked signal.
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        os.setsid()
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.close(null)
        os.dup2(output_w, 1)
        os.dup2(output_w, 2)
        os.close(output_w)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        module, _, name = str(request["target"]).partition(":")
        func = getattr(importlib.import_module(module), name)
        record = func(request["case"], request.get("trace_dir"))
        data = json.dumps(record, allow_nan=False, default=str).encode()
        with open(result_w, "wb", closefd=True) as out:
            out.write(data)
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException:
        with contextlib.suppress(BaseException):
            traceback.print_exc()
    finally:
        with contextlib.suppress(BaseException):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)


def _killpg(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, signal.SIGKILL)


def _has_exited(pid: int) -> bool:
    """Whether the case process has exited, leaving it unreaped (its pid stays its group's)."""
    flags = os.WEXITED | os.WNOHANG | os.WNOWAIT
    return os.waitid(os.P_PID, pid, flags) is not None


def _watch(pid: int, result_r: int, output_r: int, inbox: Lines) -> tuple[bytes, bytes, bool]:
    """Read the case's pipes until it has ended; kill it if the worker goes away.

    Returns:
        The record's bytes, the output's tail, and whether the worker is still there.
    """
    selector = selectors.DefaultSelector()
    selector.register(result_r, selectors.EVENT_READ, "result")
    selector.register(output_r, selectors.EVENT_READ, "output")
    selector.register(inbox.fd, selectors.EVENT_READ, "inbox")
    pidfd: int | None = None
    with contextlib.suppress(AttributeError, OSError):
        pidfd = os.pidfd_open(pid)
        selector.register(pidfd, selectors.EVENT_READ, "exit")
    record, output = bytearray(), bytearray()
    pipes = {result_r, output_r}
    worker = True
    exited_at: float | None = None
    while True:
        timeout: float | None
        if exited_at is not None:
            timeout = _DRAIN_S - (time.monotonic() - exited_at)
            if not pipes or timeout <= 0:
                break  # read to the end, or something outside its group holds the pipes
        else:
            timeout = None if pidfd is not None else 0.05
        for key, _ in selector.select(timeout):
            if key.data == "inbox":
                if not inbox.fill():  # the worker is gone: so is the case
                    worker = False
                    selector.unregister(key.fd)
                    _killpg(pid)
            elif key.data == "exit":
                selector.unregister(key.fd)
                exited_at = time.monotonic()
                _killpg(pid)  # what the case left in its group goes with it
            else:
                chunk = os.read(key.fd, 1 << 16)
                if not chunk:
                    selector.unregister(key.fd)
                    pipes.discard(key.fd)
                elif key.data == "result":
                    record += chunk
                else:
                    output += chunk
                    del output[:-STDERR_TAIL]
        if exited_at is None and pidfd is None and _has_exited(pid):
            exited_at = time.monotonic()
            _killpg(pid)
    selector.close()
    if pidfd is not None:
        os.close(pidfd)
    return bytes(record), bytes(output), worker


_running: int | None = None
"""The case process running now (its pid is its group): what a SIGTERM kills first."""


def _on_term(signum: int, _frame: object) -> None:
    """SIGTERM (the worker died, or someone asks): the case's group first, then the server."""
    if _running is not None:
        _killpg(_running)
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def _run(request: dict[str, Any], inbox: Lines, replies: int) -> bool:
    """Fork one case process and report on it; ``False`` if the worker went away."""
    global _running
    result_r, result_w = os.pipe()
    output_r, output_w = os.pipe()
    # No SIGTERM between the fork and knowing the case's pid: it would be left running.
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the case process (measured in its own right)
        os.close(result_r)
        os.close(output_r)
        os.close(replies)
        inbox.close()
        _case_process(request, result_w, output_w, mask)
    _running = pid
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    os.close(result_w)
    os.close(output_w)
    try:
        send(replies, {"started": pid})
    except OSError:
        _killpg(pid)
    record, output, worker = _watch(pid, result_r, output_r, inbox)
    os.close(result_r)
    os.close(output_r)
    _running = None  # ended (or killed, its worker gone), its group killed: nothing to kill
    _, status = os.waitpid(pid, 0)
    reply = {
        "ended": pid,
        "status": os.waitstatus_to_exitcode(status),
        "record": record.decode("utf-8", "replace") if record else None,
        "stderr": output.decode("utf-8", "replace"),
    }
    if not worker:
        return False
    try:
        send(replies, reply)
    except OSError:
        return False
    return True


def serve(parent: int | None = None) -> int:
    """The server's loop: import once, then one forked case process per request.

    Args:
        parent: The worker's pid: on Linux the server ends when that process does.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the worker decides; a terminal's ^C is not ours
    signal.signal(signal.SIGTERM, _on_term)
    if parent is not None:
        die_with_parent(signal.SIGTERM, parent)
    # Replies go out on a descriptor of their own: whatever an import prints to standard
    # output lands on standard error, never in the middle of a reply.
    replies = os.dup(1)
    os.dup2(2, 1)
    from pirate_bt.campaign.case import PRELOAD, prepare

    _import(list(PRELOAD))
    with contextlib.suppress(Exception):  # a case meets the same failure and reports it
        prepare()
    gc.collect()
    gc.freeze()
    inbox = Lines(0)
    while True:
        try:
            request = inbox.read()
        except EOFError:
            return 0
        if request is None:  # pragma: no cover - no deadline, so never
            continue
        wanted = [*request.get("preload", ()), str(request["target"]).partition(":")[0]]
        if any(name not in sys.modules for name in wanted):
            _import(wanted)
            gc.freeze()
        if not _run(request, inbox, replies):
            return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m pirate_bt.campaign.child [--parent PID]``."""
    args = sys.argv[1:] if argv is None else argv
    parent = int(args[1]) if len(args) >= 2 and args[0] == "--parent" else None
    return serve(parent)


if __name__ == "__main__":
    raise SystemExit(main())

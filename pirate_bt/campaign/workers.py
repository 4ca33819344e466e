"""The worker's end of the case servers: start once, fork a process per case, enforce its limit.

Each worker of a campaign's executor (a process of the local pool, a thread of a
Dask worker, a thread of an executor of your own) runs its cases through a
:class:`CaseServer`: a long-lived ``python -m pirate_bt.campaign.child`` that has
imported pirate_bt, py_trees, pydantic, the simulator and the rest once, and forks
one case process per case (see :mod:`pirate_bt.campaign.child`). Servers are kept
per worker process, one per thread that needs one, and reused while the process's
working folder and environment stay as they were when the server started (a new
server otherwise, so a case sees what a freshly started process would).

:func:`run_in_server` is what :func:`pirate_bt.campaign.engine.run_isolated` does
with a case. Whatever happens to the case, the record says it and the worker goes
on:

- the case returns: its record;
- it raises, crashes (``os._exit``, a segfault), or is killed: an ``error`` record
  with its exit status and the last line it wrote; the server forks the next case
  as if nothing happened;
- it runs past its wall-time limit: its process group is killed, a ``timeout``
  record;
- the server itself dies or stops answering (a case that kills it, a broken
  import): it is killed, the case is an ``error`` (or ``timeout``), and the next
  case starts a new server.

The local pool starts its workers' servers as the workers start
(:func:`start_pool_worker`, the pool's initializer); on Dask a worker plugin does
(:mod:`pirate_bt.campaign.cluster`). Anywhere else the first case starts one.

A pool worker ends with the campaign's process, and a server with its worker
(Linux: ``PR_SET_PDEATHSIG``): a campaign killed with ``SIGKILL`` leaves nothing
running. Each pool worker notes which call it runs (:func:`tracked`), so that when
one dies the pool can tell the case that was running in it from those its
replacement may run again (:func:`pool_markers`).
"""

from __future__ import annotations

import atexit
import contextlib
import json
import logging
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, ParamSpec, TypeVar

from pirate_bt.campaign.case import error_record, preload
from pirate_bt.errors import shown

if TYPE_CHECKING:
    from pirate_bt.campaign.child import Lines

# pirate_bt.campaign.child is imported where it is used, never by this package's
# import: the server runs it as ``python -m pirate_bt.campaign.child``, and a copy
# imported beside that __main__ made every server print runpy's RuntimeWarning
# ("found in sys.modules ... unpredictable behaviour"), the last words a dead
# server's error row then quoted as its cause.

__all__ = [
    "CaseServer",
    "idle_servers",
    "pool_markers",
    "prestart",
    "run_in_server",
    "start_pool_worker",
    "stop_servers",
    "tracked",
]

_log = logging.getLogger(__name__)

_GRACE_S = 10.0
"""How long a server may take to report a case it was told was killed."""

_START_S = 60.0
"""How long a server may take to start a case beyond the case's own limit (a new
server imports everything first)."""

_Origin = tuple[str, str, tuple[tuple[str, str], ...]]


def _origin() -> _Origin:
    """What a case process inherits from where its server started."""
    try:
        cwd = os.getcwd()
    except OSError:
        cwd = ""
    return sys.executable, cwd, tuple(sorted(os.environ.items()))


@dataclass
class _Reply:
    """How a case ended, as its server told it (or as the worker saw it)."""

    kind: str  # "ended", "timeout" or "lost"
    status: int = 0
    record: str | None = None
    stderr: str = ""
    reason: str = ""
    started: bool = True
    server_ok: bool = True


class CaseServer:
    """One case server process and its pipes, used by one thread at a time."""

    def __init__(self) -> None:
        self.origin = _origin()
        self.owner = os.getpid()
        self.generation = _generation
        self.cases = 0
        # Its own messages (a broken import), read back if it dies: a file never fills.
        self._stderr: IO[bytes] = tempfile.TemporaryFile()  # noqa: SIM115 - closed in _close
        self.proc = subprocess.Popen(
            # --parent: the server ends with this process (Linux), even if its pipes do not close
            [sys.executable, "-m", "pirate_bt.campaign.child", "--parent", str(os.getpid())],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
            start_new_session=True,
            env=dict(os.environ, PYTHONHASHSEED="0"),
            bufsize=0,
        )
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self._in = self.proc.stdin
        from pirate_bt.campaign.child import Lines

        self._lines: Lines = Lines(self.proc.stdout.fileno())

    def alive(self) -> bool:
        return self.proc.poll() is None

    def run(self, request: bytes, limit_s: float) -> _Reply:
        """Send one case and wait for its end, at most ``limit_s`` after its process started."""
        try:
            data = memoryview(request)
            while data:
                data = data[os.write(self._in.fileno(), data) :]
        except OSError as exc:
            return _Reply(
                "lost", reason=f"case server gone ({exc})", started=False, server_ok=False
            )
        case_pid: int | None = None
        try:
            # A new server imports first: that is not the case's time.
            started = self._lines.read(time.monotonic() + limit_s + _START_S)
            if started is None:
                return _Reply("lost", reason="case server did not start the case", server_ok=False)
            case_pid = int(started["started"])
            ended = self._lines.read(time.monotonic() + limit_s)
        except EOFError:
            if case_pid is not None:
                _killpg(case_pid)
            where = "before" if case_pid is None else "while"
            return _Reply(
                "lost",
                reason=f"case worker died {where} the case ran",
                started=case_pid is not None,
                server_ok=False,
            )
        except (ValueError, KeyError, TypeError) as exc:
            if case_pid is not None:
                _killpg(case_pid)
            return _Reply("lost", reason=f"case worker out of step: {exc}", server_ok=False)
        except BaseException:
            if case_pid is not None:
                _killpg(case_pid)
            raise
        self.cases += 1
        if ended is None:  # over its limit: its whole group goes, the server tells of it
            _killpg(case_pid)
            try:
                told = self._lines.read(time.monotonic() + _GRACE_S)
            except (EOFError, ValueError):
                told = None
            return _Reply("timeout", server_ok=told is not None and told.get("ended") == case_pid)
        if ended.get("ended") != case_pid:
            return _Reply("lost", reason="case worker out of step", server_ok=False)
        return _Reply(
            "ended",
            status=int(ended.get("status", 1)),
            record=ended.get("record"),
            stderr=str(ended.get("stderr") or ""),
        )

    def last_words(self) -> str:
        """How the server ended and the last line it wrote (once it has died)."""
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=1.0)
        code = self.proc.returncode
        if code is None:
            status = "killed"
        elif code < 0:
            status = f"killed by {signal.Signals(-code).name}"
        else:
            status = f"exit status {code}"
        self._stderr.seek(0, os.SEEK_END)
        self._stderr.seek(max(0, self._stderr.tell() - 4096))
        text = self._stderr.read().decode("utf-8", "replace")
        return f"{status}: {_last_line(text)}"

    def stop(self, wait_s: float = 2.0) -> None:
        """Close its input (it exits), kill it if it lingers."""
        with contextlib.suppress(OSError):
            self._in.close()
        try:
            self.proc.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            self.kill()
        self._close()

    def kill(self) -> None:
        with contextlib.suppress(OSError):
            self.proc.kill()
        with contextlib.suppress(OSError):
            self._in.close()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5.0)
        self._close()

    def _close(self) -> None:
        self._lines.close()
        if self.proc.stdout is not None:
            with contextlib.suppress(OSError):
                self.proc.stdout.close()
        with contextlib.suppress(OSError):
            self._stderr.close()

    def forget(self) -> None:
        """In a forked copy of the worker: let go of the pipes without touching the server."""
        self.owner = -1
        self._close()
        with contextlib.suppress(OSError):
            self._in.close()


def _killpg(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, signal.SIGKILL)


def _last_line(text: str) -> str:
    line = next((ln for ln in reversed(text.strip().splitlines()) if ln.strip()), "no message")
    return line[-300:]


# --- the servers of this process -------------------------------------------------------

_lock = threading.Lock()
_idle: list[CaseServer] = []
_generation = 0


def _forked() -> None:
    """In a fork of this process (a pool worker): the servers are the parent's, not ours."""
    global _lock
    _lock = threading.Lock()  # another thread may have held it at the fork
    for server in _idle:
        server.forget()
    _idle.clear()


os.register_at_fork(after_in_child=_forked)


def _take() -> CaseServer:
    origin = _origin()
    stale: list[CaseServer] = []
    found: CaseServer | None = None
    with _lock:
        while _idle:
            server = _idle.pop()
            if server.origin == origin and server.alive():
                found = server
                break
            stale.append(server)
    for server in stale:
        server.stop(wait_s=0.5)
    return found if found is not None else CaseServer()


def _give(server: CaseServer) -> None:
    keep = server.alive() and server.owner == os.getpid() and server.generation == _generation
    if keep:
        with _lock:
            _idle.append(server)
    else:
        server.stop(wait_s=0.5)


def prestart(count: int = 1) -> None:
    """Start servers until ``count`` are idle (they import while the worker waits for work).

    The local pool's initializer; the Dask worker plugin's set-up.
    """
    with _lock:
        missing = count - len(_idle)
    for _ in range(missing):
        try:
            server = CaseServer()
        except OSError as exc:  # the first case tries again, and reports it
            _log.warning("cannot start a case server: %s", exc)
            return
        with _lock:
            _idle.append(server)


def idle_servers() -> int:
    """How many case servers this process keeps ready (none run a case now)."""
    with _lock:
        return sum(1 for server in _idle if server.alive())


def stop_servers() -> None:
    """Stop this process's idle servers; those running a case stop when it ends.

    Called when the process exits, and by the Dask worker plugin's tear-down.
    """
    global _generation
    with _lock:
        _generation += 1
        servers = list(_idle)
        _idle.clear()
    for server in servers:
        server.stop(wait_s=2.0)


atexit.register(stop_servers)


def run_in_server(case: dict[str, Any], trace_dir: str | None, target: str) -> dict[str, Any]:
    """Run one case in a process forked from this worker's case server; its record.

    Args:
        case: The case (its ``timeout_s`` is the wall-time limit).
        trace_dir: Where the case may keep its trace.
        target: ``module:function`` the case process calls.

    Returns:
        The case's own record, or an ``error``/``timeout`` record made here.
    """
    started = time.perf_counter()
    limit = float(case["timeout_s"])
    message = {
        "target": target,
        "case": case,
        "trace_dir": trace_dir,
        "preload": list(preload(case, trace_dir)),
    }
    request = (json.dumps(message, allow_nan=False, default=str) + "\n").encode()
    for attempt in range(2):
        server = _take()
        try:
            reply = server.run(request, limit)
        except BaseException:  # Ctrl-C: the server kills a case it started as its input closes
            server.stop(wait_s=2.0)
            raise
        if reply.server_ok:
            _give(server)
        else:
            if reply.kind == "lost":
                reply.reason = f"{reply.reason} ({server.last_words()})"
            server.kill()
        # A server that had died idle is replaced, and the case sent again, once.
        if reply.kind == "lost" and not reply.started and attempt == 0:
            continue
        break
    wall = time.perf_counter() - started
    if reply.kind == "timeout":
        return error_record(case, "timeout", f"killed after its {limit:g} s wall-time limit", wall)
    if reply.kind == "lost":
        return error_record(case, "error", reply.reason, wall)
    if reply.status == 0 and reply.record:
        try:
            record = json.loads(reply.record)
        except ValueError:
            pass
        else:
            if isinstance(record, dict):
                return record
    if reply.status < 0:
        status = f"killed by {signal.Signals(-reply.status).name}"
    else:
        status = f"exit status {reply.status}"
    said = f"case process died ({status}) in {_what_ran(case)}: {_last_line(reply.stderr)}"
    return error_record(case, "error", said, wall)


def _what_ran(case: dict[str, Any]) -> str:
    """What the case ran, for the row of a case process that died: a plug-in navigator
    that closed the process's files left only *OSError: [Errno 9] Bad file descriptor*,
    naming nothing. Its run and seed, not its id: rows alike but for the seed count
    as one reason in the report."""
    what = next(
        (
            f"{key} {shown(Path(str(case[key])).name if key != 'navigator' else case[key])}"
            for key in ("navigator", "tree", "route")
            if case.get(key)
        ),
        None,
    )
    run = f"run {shown(case.get('run'))}, seed {case.get('seed')}"
    return f"{what} ({run})" if what else run


# --- a worker of the local pool ---------------------------------------------------------

_P = ParamSpec("_P")
_T = TypeVar("_T")

_marker: Path | None = None
"""This pool worker's note of the call it runs (``MARKERS/PID``), once it has started."""

_TERMINATED = "terminated"


def start_pool_worker(parent: int | None, markers: str) -> None:
    """The local pool's initializer: die with the campaign, note calls, start a server.

    Args:
        parent: The campaign's pid (the worker's parent): on Linux the worker is
            killed when that process dies (``None``: not checked, the parent is
            another process, a fork server's).
        markers: The folder where the worker notes the call it runs.
    """
    global _marker
    from pirate_bt.campaign.child import die_with_parent

    die_with_parent(signal.SIGKILL, parent)
    _marker = Path(markers) / str(os.getpid())
    signal.signal(signal.SIGTERM, _on_pool_term)
    prestart()


def _on_pool_term(signum: int, _frame: object) -> None:
    """Terminated (by the pool, once another worker died): say so, then die of it."""
    if _marker is not None:
        with contextlib.suppress(OSError), _marker.open("a", encoding="utf-8") as f:
            f.write(f"{_TERMINATED}\n")
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def tracked(token: int, fn: Callable[_P, _T], *args: _P.args, **kwargs: _P.kwargs) -> _T:
    """Call ``fn`` in a pool worker, its ``token`` noted while it runs."""
    if _marker is None:
        return fn(*args, **kwargs)
    _marker.write_text(f"{token}\n", encoding="utf-8")
    try:
        return fn(*args, **kwargs)
    finally:
        with contextlib.suppress(OSError):
            _marker.write_text("", encoding="utf-8")


def pool_markers(markers: str) -> dict[int, bool]:
    """Once a pool's workers have all ended: the calls they were running, and whether
    each one's worker was terminated by the pool (``True``) or died of itself (``False``).

    The notes are removed (the next pool's workers start without any).
    """
    running: dict[int, bool] = {}
    for path in Path(markers).iterdir():
        with contextlib.suppress(OSError):
            lines = path.read_text(encoding="utf-8").split()
            path.unlink()
            if lines and lines[0].isdigit():
                running[int(lines[0])] = _TERMINATED in lines[1:]
    return running

"""An installed navigator's checks rehearsed in a forked process first.

A campaign makes each distinct navigator once, and checks its map, in its own
process before any case runs (:func:`pirate_bt.campaign.navchecks.check_navigator`),
so that a bad name or parameter costs nothing. That is the plug-in's code running in
the campaign's process: an ``os._exit(7)`` in its ``__init__`` or ``check_map`` ended
``pirate-bt validate`` and ``campaign`` with exit 7 and not a word, a ``SIGKILL`` of
its own with 137, and one that never returned hung them for ever; the cases, which
each run in a process of their own under ``case_timeout``, would have said it.

:func:`rehearse` runs the same checks in a forked child first, its output thrown
away, and waits at most the case timeout (each case makes the navigator within it):
a child that ends before it says it finished, or is still at it then, is the
navigator's fault, said in one line; one that finishes lets the checks run here,
where they raise what they raise. The built-in navigators are ours and are not
rehearsed.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import signal
import threading
import time
from collections.abc import Callable

from pirate_bt.errors import InputError

__all__ = ["rehearse"]

_log = logging.getLogger(__name__)

_DONE = b"1"


def rehearse(name: str, check: Callable[[], object], timeout_s: float) -> None:
    """Run ``check()`` in a forked child and wait for it at most ``timeout_s``.

    Whatever ``check()`` raises in the child is ignored (it raises it again here).

    Raises:
        InputError: the child ended without finishing (``os._exit``, a signal) or was
            still running after ``timeout_s``; it and its process group are killed.
    """
    if not hasattr(os, "fork"):  # pragma: no cover - campaigns need POSIX (docs)
        return
    if threading.active_count() > 1:
        # a fork copies only this thread: a lock another thread holds (the import lock,
        # logging's) stays held in the child for ever, and a navigator fine in every case
        # would be refused after the case timeout. Planner code calling run_campaign
        # from a threaded program is not rehearsed; the command line has one thread.
        _log.debug("navigator %r not rehearsed: %d threads", name, threading.active_count())
        return
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child (its coverage is not gathered)
        try:
            os.close(read_end)
            os.setpgid(0, 0)  # what it starts goes with it
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            me = os.getpid()
            with contextlib.suppress(BaseException):
                check()
            if os.getpid() == me:  # not a process the navigator forked, going on
                os.write(write_end, _DONE)
        finally:
            os._exit(0)
    os.close(write_end)
    with contextlib.suppress(OSError):  # the child may have set it itself already
        os.setpgid(pid, pid)
    said: bytes | None = None
    status: int | None = None
    try:
        said, status = _wait_for(read_end, pid, timeout_s)
    finally:
        os.close(read_end)
        if status is None:  # still running (or an error here): killed, then reaped
            _kill(pid)
            status = _reap(pid)
        with contextlib.suppress(OSError):  # what it left behind in its group
            os.killpg(pid, signal.SIGKILL)
    if said == _DONE:
        return
    if said is None:
        raise InputError(
            f"navigator {name!r} was still being made (or checking its map) after"
            f" {timeout_s:g} s, the case timeout: each case would time out making it"
        )
    raise InputError(
        f"navigator {name!r} ended the process as it was made (or checked its map):"
        f" {_status(status)}; each case would die of it"
    )


def _wait_for(fd: int, pid: int, timeout_s: float) -> tuple[bytes | None, int | None]:
    """The child's word (``b""``: it ended without one, ``None``: none by ``timeout_s``)
    and its wait status once it has ended (``None`` while it runs). Its end is watched
    as well as the pipe: a process it forked may hold the pipe open after it."""
    deadline = time.monotonic() + timeout_s
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return None, None
        ready, _, _ = select.select([fd], [], [], min(left, 0.5))
        if ready:
            said = os.read(fd, 1)
            return said, (_reap(pid) if said == _DONE else _ended(pid))
        ended = _ended(pid)
        if ended is not None:  # its word may have come since the select: read it
            ready, _, _ = select.select([fd], [], [], 0)
            return (os.read(fd, 1) if ready else b""), ended


def _ended(pid: int) -> int | None:
    """The child's wait status if it has ended (reaped), else ``None``."""
    try:
        done, status = os.waitpid(pid, os.WNOHANG)
    except ChildProcessError:  # pragma: no cover - reaped by someone else
        return 0
    return status if done else None


def _kill(pid: int) -> None:
    for kill in (os.killpg, os.kill):
        with contextlib.suppress(OSError):
            kill(pid, signal.SIGKILL)


def _reap(pid: int) -> int:
    while True:
        try:
            return os.waitpid(pid, 0)[1]
        except InterruptedError:  # pragma: no cover - retried by Python itself
            continue
        except ChildProcessError:  # pragma: no cover - reaped by someone else
            return 0


def _status(status: int) -> str:
    """``exit status 7`` or ``killed by SIGKILL``."""
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            return f"killed by {signal.Signals(number).name}"
        except ValueError:  # pragma: no cover - a signal Python has no name for
            return f"killed by signal {number}"
    return f"exit status {os.WEXITSTATUS(status)}"

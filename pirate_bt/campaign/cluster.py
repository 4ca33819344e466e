"""Campaigns on Dask: the connection, and case servers that start once per Dask worker.

Imported only when a campaign goes to a Dask scheduler (``distributed`` is an
optional extra). :func:`dask_executor` connects, registers
:class:`CaseServerPlugin` and yields the client's ``concurrent.futures``
executor. The plugin starts one case server per thread of every Dask worker
(the imports happen there, once, while the campaign is being submitted), and
the servers stay with their worker: the next campaign on the same cluster finds
them ready, and they end with the worker (the plugin's tear-down, or the
worker's pipes closing). ``client.unregister_worker_plugin(PLUGIN_NAME)`` stops
them sooner. A worker started with ``dask worker --preload
pirate_bt.campaign.cluster`` starts its servers as it starts (:func:`dask_setup`).

A case on Dask then runs exactly as on the local pool: in a process forked from
its worker's server, with the same limits and the same records
(:mod:`pirate_bt.campaign.workers`).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from concurrent.futures import Executor
from contextlib import contextmanager
from typing import Any

from distributed import Client
from distributed.diagnostics.plugin import WorkerPlugin

from pirate_bt.campaign.cancelled import CasesNotRun, LostSchedulerNoise
from pirate_bt.campaign.workers import prestart, stop_servers
from pirate_bt.errors import InputError, LinkError, said_of

__all__ = ["PLUGIN_NAME", "CaseServerPlugin", "dask_executor", "dask_setup"]

_log = logging.getLogger(__name__)

PLUGIN_NAME = "pirate_bt-case-servers"


def _threads(worker: Any) -> int:
    state = getattr(worker, "state", worker)
    return max(1, int(getattr(state, "nthreads", 1) or 1))


class CaseServerPlugin(WorkerPlugin):
    """Starts a worker's case servers (one per thread) when set up, stops them at tear-down.

    Idempotent: a second campaign's registration leaves the first's in place, and
    its servers.
    """

    idempotent = True

    def setup(self, worker: Any) -> None:
        prestart(_threads(worker))

    def teardown(self, worker: Any) -> None:
        stop_servers()


def dask_setup(worker: Any) -> None:
    """``dask worker --preload pirate_bt.campaign.cluster``: start the servers with the worker."""
    prestart(_threads(worker))


def _wait_for_file(path: str, timeout_s: float) -> None:
    """Wait up to ``timeout_s`` for a scheduler file a starting scheduler is to write.

    Raises:
        InputError: it is not a file by then (a folder, or still missing).
    """
    import os
    import time

    end = time.monotonic() + timeout_s
    while not os.path.isfile(path):
        if os.path.isdir(path):
            raise InputError(f"scheduler_file: {path} is a directory, not a scheduler file")
        if time.monotonic() >= end:
            raise InputError(
                f"scheduler_file: no scheduler file at {path} after {timeout_s:g} s; start"
                " the scheduler with --scheduler-file, or give a longer scheduler_timeout"
            )
        time.sleep(0.05)


def _scheduler_address(path: str, timeout_s: float) -> str:
    """The address in a scheduler file (``{"address": "tcp://host:8786", ...}``).

    A file that does not parse is read again for up to half a second (at most
    ``timeout_s``): a starting scheduler may not have finished writing it.

    Raises:
        InputError: It is not a Dask scheduler file (Dask's client failed on one with
            a bare ``AssertionError`` or ``TypeError``).
    """
    import json
    import time

    end = time.monotonic() + min(0.5, timeout_s)
    while True:
        try:
            with open(path, "rb") as file:
                data: Any = json.loads(file.read())
            break
        except ValueError as exc:  # not JSON (or not yet all of it), not text
            if time.monotonic() >= end:
                why = f"not JSON: {exc}"
                raise InputError(
                    f"scheduler_file {path}: not a Dask scheduler file ({why})"
                ) from None
            time.sleep(0.05)
        except OSError as exc:
            raise InputError(f"scheduler_file {path}: cannot read it: {exc}") from None
    if not isinstance(data, dict):
        why = f"JSON {type(data).__name__}, not an object with an address"
    elif "address" not in data:
        why = 'no "address" in it'
    elif not isinstance(data["address"], str) or not data["address"].strip():
        why = f'its "address" is {data["address"]!r}, not an address like tcp://host:8786'
    else:
        return data["address"]
    raise InputError(f"scheduler_file {path}: not a Dask scheduler file ({why})")


class _Unreachable(Exception):
    """Nothing accepted a connection at the address within the timeout."""


async def _handshake(address: str, timeout_s: float) -> None:
    """Connect to ``address`` and complete Dask's handshake, then hang up.

    Dask's ``connect`` bounds the TCP connection by its timeout but not the
    handshake after it: a far end that accepts and never answers held it for ever,
    and one that answers in another protocol (an HTTP server's ``400``) had its
    text read as a frame length (a ``MemoryError``). Here the whole is bounded.

    Raises:
        _Unreachable: No connection could be made (Dask's ``OSError``).
        Exception: Anything else: something answered, not a Dask scheduler.
    """
    import asyncio

    from distributed.comm.core import CommClosedError, connect
    from distributed.security import Security

    # as the client will connect: with the TLS of Dask's configuration (a tls://
    # scheduler was refused here, "its reply is not Dask's protocol", for want of it)
    security: Any = Security()  # type: ignore[no-untyped-call]
    try:
        # connect is untyped; its own timeout covers the TCP connection only.
        comm: Any = await asyncio.wait_for(
            connect(  # type: ignore[no-untyped-call]
                address, timeout=timeout_s, **security.get_connection_args("client")
            ),
            timeout_s + 0.5,
        )
    except TimeoutError:  # before OSError: TimeoutError is one
        raise TimeoutError(
            f"it took the connection but did not answer Dask's handshake within {timeout_s:g} s"
        ) from None
    except CommClosedError as exc:  # before OSError: it is one, but it came after connecting
        raise ConnectionError(f"it took the connection, then closed it ({exc})") from None
    except OSError as exc:
        raise _Unreachable(str(exc)) from None
    comm.abort()


def _no_tls() -> bool:
    """Whether Dask's configuration gives its client no TLS to connect with."""
    from distributed.security import Security

    security: Any = Security()  # type: ignore[no-untyped-call]
    return security.get_connection_args("client").get("ssl_context") is None


def _check_scheduler(address: str, timeout_s: float) -> None:
    """Refuse an address where no Dask scheduler completes a handshake within ``timeout_s``.

    It runs on an event loop of its own, in a thread of its own (the caller may be
    in a running loop), which has ended when this returns.

    Raises:
        InputError: Nothing took the connection, or what did is not a Dask
            scheduler (it did not answer, answered in another protocol, hung up).
    """
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import registry
    from distributed.comm.addressing import get_address_host_port, parse_address

    try:  # here, so that a ValueError from the far end is its, not the address's
        scheme, _ = parse_address(address)
        registry.get_backend(scheme)
        if scheme in ("tcp", "tls", "ws", "wss"):
            get_address_host_port(address)
    except Exception as exc:
        raise InputError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
    if scheme == "tls" and _no_tls():  # Dask's TypeError was said as the far end's reply
        raise InputError(
            f"cannot reach the Dask scheduler at {address}: no TLS is configured for"
            " Dask's client (distributed.comm.tls.ca-file, .client.cert, .client.key)"
        )
    with ThreadPoolExecutor(1, thread_name_prefix="pirate_bt-dask-check") as pool:
        future = pool.submit(asyncio.run, _handshake(address, timeout_s))
        try:
            future.result()
        except _Unreachable as exc:
            raise InputError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
        except (TimeoutError, ConnectionError) as exc:
            raise InputError(f"no Dask scheduler answered at {address}: {exc}") from None
        except Exception as exc:  # MemoryError too: what it sent was read as a frame length
            raise InputError(
                f"no Dask scheduler answered at {address}: its reply is not Dask's protocol"
                f" ({type(exc).__name__}: {said_of(exc, 120)})"
            ) from None


def _wait_for_a_worker(client: Any, address: str, timeout_s: float) -> None:
    """Wait up to ``timeout_s`` for the scheduler to have a worker.

    With none, the cases were handed to it and the campaign waited for ever, for
    workers nobody had started (or a SLURM job that never left the queue).

    Raises:
        LinkError: No worker within ``timeout_s``; nothing was handed to the cluster.
    """
    try:
        client.wait_for_workers(1, timeout=timeout_s)
    except TimeoutError:
        raise LinkError(
            f"the Dask scheduler at {address} has no workers after {timeout_s:g} s: start"
            f" workers (dask worker {address}), or give a longer scheduler_timeout"
        ) from None


class _Watched(Executor):
    """The client's executor, watching that the cluster keeps a worker while cases are
    out: one whose workers were all lost waited for ever for new ones, the cases out
    neither run nor given back. With no worker for ``timeout_s`` it cancels the cases
    out (the campaign stops as when its scheduler went away: they have no row, a
    resume runs them) and says so in :attr:`gave_up`."""

    def __init__(self, executor: Executor, client: Any, timeout_s: float) -> None:
        import threading

        self._executor = executor
        self._client = client
        self._timeout_s = timeout_s
        self._out: set[Any] = set()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.gave_up = False
        """Whether it cancelled the cases out: the cluster had no worker for the timeout."""
        self._thread = threading.Thread(
            target=self._watch, name="pirate_bt-dask-watch", daemon=True
        )
        self._thread.start()

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Any:
        future = self._executor.submit(fn, *args, **kwargs)
        with self._lock:
            self._out.add(future)
        future.add_done_callback(self._back)
        return future

    def _back(self, future: Any) -> None:
        with self._lock:
            self._out.discard(future)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self.stop_watching()
        if cancel_futures:  # Dask's ClientExecutor.shutdown takes no cancel_futures
            with self._lock:
                out = list(self._out)
            for future in out:
                future.cancel()
        self._executor.shutdown(wait=wait)

    def stop_watching(self) -> None:
        """End the watch (its thread is gone within one wait of its client)."""
        self._stop.set()

    def _watch(self) -> None:
        import time

        since: float | None = None  # when the cluster was last seen with no worker
        while not self._stop.wait(0.5):
            with self._lock:
                waiting = bool(self._out)
            try:  # the count alone: not every worker's description, twice a second
                workers = self._client.scheduler_info(n_workers=0).get("n_workers")
            except Exception:  # the scheduler gone: the client gives the cases back itself
                workers = None
            if not waiting or workers != 0 or self._client.status != "running":
                since = None
                continue
            now = time.monotonic()
            since = now if since is None else since
            if now - since < self._timeout_s:
                continue
            with self._lock:
                out = list(self._out)
            self.gave_up = True
            for future in out:
                future.cancel()
            return


@contextmanager
def dask_executor(
    scheduler: str | None, scheduler_file: str | None, timeout_s: float = 10.0
) -> Iterator[tuple[Executor, str]]:
    """The executor of a Dask cluster's client, with case servers on its workers.

    ``timeout_s``: how long to keep trying to reach the scheduler (one that is still
    starting may refuse a connection for a while). The handshake is bounded by it
    too, whatever the far end does; the client starts only once a Dask scheduler
    has answered. Then it waits as long again for the scheduler's first worker.

    Raises:
        InputError: The scheduler cannot be reached or does not answer as one, or
            its scheduler file is not there within ``timeout_s`` (Dask's client would
            wait for it for ever) or is not a scheduler file.
        LinkError: The scheduler has no worker within ``timeout_s`` after it answered
            (nothing has been handed to it).
    """
    if scheduler is not None:
        address = scheduler
    elif scheduler_file is not None:
        _wait_for_file(scheduler_file, timeout_s)
        address = _scheduler_address(scheduler_file, timeout_s)
    else:  # Client(None) would start a local cluster
        raise InputError("give a Dask scheduler address or scheduler file")
    _check_scheduler(address, timeout_s)
    try:
        # Client is untyped (distributed types its plugins, not its client).
        client: Any = Client(address, timeout=timeout_s)  # type: ignore[no-untyped-call]
    except Exception as exc:  # it answered the check, then not the client
        raise InputError(
            f"cannot reach the Dask scheduler at {address}:"
            f" {type(exc).__name__}: {said_of(exc, 120)}"
        ) from None
    executor: _Watched | None = None
    noise = LostSchedulerNoise()  # a scheduler gone is said once, by the campaign
    logging.getLogger("distributed.client").addFilter(noise)
    try:
        _wait_for_a_worker(client, address, timeout_s)
        try:
            client.register_plugin(CaseServerPlugin(), name=PLUGIN_NAME)
        except Exception as exc:  # the cases still start their servers themselves
            _log.warning("case servers not started ahead on the Dask workers: %s", exc)
        executor = _Watched(client.get_executor(pure=False), client, timeout_s)
        nworkers = len(client.scheduler_info().get("workers", {}))
        yield executor, f"Dask cluster at {client.scheduler.address} ({nworkers} workers)"
        executor.shutdown(wait=False)
    except CasesNotRun as exc:  # its cases cancelled: say whose, and why when it is known
        if executor is not None and executor.gave_up:
            raise LinkError(
                f"the Dask scheduler at {address} has had no workers for {timeout_s:g} s"
                f" (they were lost); the cases not run were cancelled; {exc.rest}"
            ) from None
        raise CasesNotRun(f"Dask cluster at {address}: {exc}") from None
    finally:
        if executor is not None:
            executor.stop_watching()  # the thread ends with its client, however it ended
        client.close()
        logging.getLogger("distributed.client").removeFilter(noise)

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

from pirate_bt.campaign.workers import prestart, stop_servers
from pirate_bt.errors import InputError

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


@contextmanager
def dask_executor(
    scheduler: str | None, scheduler_file: str | None, timeout_s: float = 10.0
) -> Iterator[tuple[Executor, str]]:
    """The executor of a Dask cluster's client, with case servers on its workers.

    ``timeout_s``: how long to keep trying to reach the scheduler (one that is still
    starting may refuse a connection for a while).

    Raises:
        InputError: The scheduler cannot be reached, or its scheduler file is not there
            within ``timeout_s`` (Dask's client would wait for it for ever).
    """
    if scheduler is None and scheduler_file is not None:
        _wait_for_file(scheduler_file, timeout_s)
    try:
        # Client is untyped (distributed types its plugins, not its client).
        client: Any = (
            Client(scheduler, timeout=timeout_s)  # type: ignore[no-untyped-call]
            if scheduler is not None
            else Client(scheduler_file=scheduler_file, timeout=timeout_s)  # type: ignore[no-untyped-call]
        )
    except (OSError, TimeoutError, ValueError) as exc:
        where = scheduler or scheduler_file
        raise InputError(f"cannot reach the Dask scheduler at {where}: {exc}") from None
    try:
        try:
            client.register_plugin(CaseServerPlugin(), name=PLUGIN_NAME)
        except Exception as exc:  # the cases still start their servers themselves
            _log.warning("case servers not started ahead on the Dask workers: %s", exc)
        executor = client.get_executor(pure=False)
        nworkers = len(client.scheduler_info().get("workers", {}))
        yield executor, f"Dask cluster at {client.scheduler.address} ({nworkers} workers)"
        executor.shutdown(wait=False)
    finally:
        client.close()

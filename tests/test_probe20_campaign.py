"""Hostile campaign runs from docs/campaigns.md (the twentieth probe).

A Dask scheduler that went away while a campaign ran: its client cancelled every
case it had not handed back, and each became an ``error`` row, ``worker lost: ``
with no reason, exit 0, and ``--resume`` never ran them (they had rows); the
client's closing logged its ``CancelledError`` tracebacks on standard error.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from pirate_bt.campaign import run_campaign
from pirate_bt.errors import InputError

pytest.importorskip("distributed")

WAIT_S = 60.0
"""How long a scheduler may take to start (ended as soon as it has)."""


@contextmanager
def _scheduler(folder: Path) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """A ``dask scheduler`` process of its own (its address, the process)."""
    file = folder / "scheduler.json"
    dask = Path(sys.executable).with_name("dask")
    if not dask.exists():
        pytest.skip(f"no {dask} to start a scheduler with")
    where = ["--host", "127.0.0.1", "--port", "0", "--scheduler-file", str(file)]
    process = subprocess.Popen(
        [str(dask), "scheduler", *where, "--no-dashboard"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + WAIT_S
        address = None
        while address is None:
            assert process.poll() is None, "the scheduler ended as it started"
            assert time.monotonic() < deadline, f"no scheduler file after {WAIT_S:g} s"
            try:
                address = json.loads(file.read_text(encoding="utf-8"))["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.05)
        yield address, process
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        process.wait()


@contextmanager
def _worker(address: str) -> Iterator[None]:
    """A ``dask worker`` process of its own at ``address``, there once this yields (a
    campaign waits for a scheduler's first worker no longer than its timeout)."""
    from distributed import Client

    dask = Path(sys.executable).with_name("dask")
    one = ["--nworkers", "1", "--nthreads", "1", "--no-nanny", "--no-dashboard"]
    process = subprocess.Popen(
        [str(dask), "worker", address, *one],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        with Client(address, timeout=WAIT_S) as client:  # type: ignore[no-untyped-call]
            client.wait_for_workers(1, timeout=WAIT_S)
        yield
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        process.wait()


def test_a_scheduler_that_goes_away_stops_the_campaign_instead_of_error_rows(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    out = tmp_path / "out"
    spec = {
        "name": "gone",
        "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.1 m"}}],
        "seeds": {"count": 3},
        "max_time": "60 s",
    }
    with _scheduler(tmp_path) as (address, process), _worker(address):

        def scheduler_dies(_line: str) -> None:  # as the campaign starts, before its cases
            process.kill()
            process.wait()

        with caplog.at_level(logging.INFO), pytest.raises(InputError) as caught:
            run_campaign(
                spec, scheduler=address, scheduler_timeout=2, output=out, echo=scheduler_dies
            )
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"Dask cluster at {address}: the executor cancelled 3 of the 3 ")
    assert message.endswith("keeps 0 of its 3 cases: run again with resume=True to run the other 3")
    # no case that never ran is a row: a resume runs them all
    assert (out / "results.jsonl").read_text(encoding="utf-8") == ""
    assert list(out.glob("traces/*")) == []
    lost = [r for r in caplog.records if r.name == "distributed.client" and r.levelname == "ERROR"]
    assert lost == [], [r.getMessage() for r in lost]


SMALL = """\
name: small
runs:
  - {name: a, tree: straight, network: straight, params: {distance: 0.1 m}}
max_time: 60 s
"""


@pytest.mark.parametrize("others", [{}, {"report.md": "# our notes\n"}])
def test_a_campaign_json_of_someone_elses_is_not_replaced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], others: dict[str, str]
) -> None:
    from pirate_bt.cli import main

    # a spec named campaign.json run into its own folder, or a project's file of that name
    spec = tmp_path / "campaign.json"
    spec.write_text(SMALL, encoding="utf-8")
    for name, text in others.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    code = main(["campaign", str(spec), "--output", str(tmp_path), "--workers", "1", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err == (
        f"pirate-bt: {spec}: the campaign's record would replace it, and it is no campaign's"
        f" ({tmp_path} holds no row); move it, or give another --output"
    )
    assert spec.read_text(encoding="utf-8") == SMALL
    for name, text in others.items():
        assert (tmp_path / name).read_text(encoding="utf-8") == text
    assert not (tmp_path / "results.jsonl").exists()


def test_a_tls_scheduler_dask_is_configured_for_runs_the_campaign(tmp_path: Path) -> None:
    # Dask's client connects with the TLS of Dask's configuration; the campaign's own
    # check of the scheduler connected without it and refused every tls:// scheduler
    # ("no Dask scheduler answered at tls://...: its reply is not Dask's protocol")
    import shutil

    import dask
    from distributed import LocalCluster
    from distributed.security import Security

    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.skip("no openssl to make a certificate with")
    cert, key = str(tmp_path / "cert.pem"), str(tmp_path / "key.pem")
    made = ["-keyout", key, "-out", cert, "-subj", "/CN=localhost", "-days", "2"]
    subprocess.run(
        [openssl, "req", "-x509", "-newkey", "rsa:2048", "-nodes", *made],
        check=True,
        capture_output=True,
        timeout=WAIT_S,
    )
    roles = ("scheduler", "worker", "client")
    security = Security(  # type: ignore[no-untyped-call]
        tls_ca_file=cert,
        require_encryption=True,
        **{
            f"tls_{role}_{part}": file
            for role in roles
            for part, file in (("cert", cert), ("key", key))
        },
    )
    config = {
        "distributed.comm.require-encryption": True,
        "distributed.comm.tls.ca-file": cert,
        "distributed.comm.tls.client.cert": cert,
        "distributed.comm.tls.client.key": key,
    }
    with (
        dask.config.set(config),
        LocalCluster(
            n_workers=1,
            threads_per_worker=1,
            processes=False,
            dashboard_address=None,
            security=security,
            protocol="tls://",
            host="127.0.0.1",
        ) as cluster,
    ):
        address = cluster.scheduler_address
        assert address.startswith("tls://")
        spec = {
            "name": "tls",
            "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.1 m"}}],
            "max_time": "60 s",
        }
        result = run_campaign(spec, scheduler=address, scheduler_timeout=WAIT_S)
    assert result.executor == f"Dask cluster at {address} (1 workers)"
    assert result.summary() == "1 runs: 1 success, 0 failed safe, 0 error, 0 timeout"


def test_a_tls_scheduler_without_tls_configured_is_said_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # it was "no Dask scheduler answered at tls://...: its reply is not Dask's
    # protocol (TypeError: ...)": nothing had answered, nothing was even sent
    from pirate_bt.cli import main

    spec = tmp_path / "s.campaign.yaml"
    spec.write_text(SMALL, encoding="utf-8")
    out = tmp_path / "out"
    options = ["--output", str(out), "--scheduler-timeout", "1 s", "--quiet"]
    code = main(["campaign", str(spec), "--scheduler", "tls://127.0.0.1:9", *options])
    assert code == 2
    assert capsys.readouterr().err.strip() == (
        "pirate-bt: cannot reach the Dask scheduler at tls://127.0.0.1:9: no TLS is configured"
        " for Dask's client (distributed.comm.tls.ca-file, .client.cert, .client.key)"
    )
    assert not out.exists()

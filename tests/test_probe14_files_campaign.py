"""Probe 14 (hostile campaign specs): what a user notices.

A ``rate`` so slow that no tick comes within ``max_time`` (``rate: 0.5 Hz`` with
``max_time: 1 s``) validated (``pirate-bt validate``: ok) and the campaign started:
every case then became an ``error`` row with a traceback, where ``pirate-bt run``
refuses the same pair at once. It is refused at the spec's ``rate``, exit 2, before any
worker starts and before the output folder is made.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.campaign import run_campaign
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from tests.hostile_support import InstantExecutor, refused

RUN = "runs:\n  - {tree: straight, network: straight, params: {distance: 0.2 m}}\n"


@pytest.mark.parametrize(
    "limits", ["rate: 0.5 Hz\nmax_time: 1 s\n", "max_time: 1 s\nrate: 1e-300 Hz\n"]
)
def test_a_rate_with_no_tick_within_max_time_is_refused_at_the_spec(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], limits: str
) -> None:
    spec = tmp_path / "slow.campaign.yaml"
    spec.write_text(f"name: slow\n{RUN}{limits}", encoding="utf-8")
    line = 4 + limits.split("\n").index(next(x for x in limits.split("\n") if "rate" in x))
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"{spec}:{line}:1: rate "), err
    assert "max_time (1 s)" in err, err
    out = tmp_path / "out"
    assert main(["campaign", str(spec), "--quiet", "--output", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{spec}:{line}:1: rate " in err, err
    assert not out.exists()


def test_a_rate_with_no_tick_within_max_time_is_refused_from_python(tmp_path: Path) -> None:
    spec = {
        "name": "slow",
        "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.2 m"}}],
        "rate": "0.5 Hz",
        "max_time": "1 s",
    }
    text = refused(
        lambda: run_campaign(spec, executor=InstantExecutor(), output=tmp_path / "o"),
        "campaign spec: rate",
        "max_time (1 s)",
        kind=InputError,
    )
    assert "Traceback" not in text
    assert not (tmp_path / "o").exists()


def test_a_rate_that_ticks_within_max_time_still_runs(tmp_path: Path) -> None:
    spec = tmp_path / "ok.campaign.yaml"
    spec.write_text(f"name: ok\n{RUN}rate: 1 Hz\nmax_time: 1 s\n", encoding="utf-8")
    assert main(["validate", str(spec)]) == 0

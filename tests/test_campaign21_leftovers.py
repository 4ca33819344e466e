"""Session 21, a campaign's leftovers: messages in a spec's words (its file, line,
column and keys), a Dask cluster with no workers."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("run", "line"),
    [
        ("  - {name: g, navigator: goal, network: lab, params: {segment: riser}, blind: true}", 3),
        ("  - name: r\n    navigator: route\n    blind: true\n    params: {route: lab.route}", 5),
    ],
    ids=["goal", "route"],
)
def test_a_blind_navigator_that_needs_a_map_is_named_at_its_blind_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], run: str, line: int
) -> None:
    spec = tmp_path / "nav.campaign.yaml"
    spec.write_text(f"name: blind\nruns:\n{run}\nseeds: {{start: 0, count: 1}}\n")
    out = tmp_path / "out"
    assert main(["campaign", str(spec), "--output", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1
    # said '(--map or map=...)': the command line's option and the API's parameter,
    # neither of which a spec has
    assert "--map" not in err and "map=" not in err
    column = spec.read_text().splitlines()[line - 1].index("blind") + 1
    assert err.startswith(f"pirate-bt: {spec}:{line}:{column}: run ")
    assert "needs a map; 'blind: true' gives the run no map: leave 'blind' out" in err
    assert not out.exists()


TWO_CASES = """\
name: two
runs:
  - {name: a, tree: straight, network: straight, params: {distance: 0.1 m}}
seeds: {start: 0, count: 2}
max_time: 60 s
"""


def test_a_dask_cluster_with_no_workers_is_a_link_error_and_resume_runs_its_cases(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    spec = tmp_path / "two.campaign.yaml"
    spec.write_text(TWO_CASES)
    out = tmp_path / "out"
    assert main(["campaign", str(spec), "--output", str(out), "-q", "--workers", "1"]) == 0
    results = out / "results.jsonl"
    kept = results.read_text().splitlines()[0] + "\n"
    results.write_text(kept)  # one case done, one to run, as an interrupted campaign's
    capsys.readouterr()
    with LocalCluster(
        n_workers=0, processes=False, dashboard_address=None, protocol="tcp://", host="127.0.0.1"
    ) as cluster:
        address = cluster.scheduler_address
        # 5 s: the scheduler, in this process, answers within it however loaded the machine
        resume = ["campaign", str(spec), "--output", str(out), "-q", "--resume"]
        # it waited for ever for workers nobody had started
        assert main([*resume, "--scheduler", address, "--scheduler-timeout", "5 s"]) == 3
        out_text, err = capsys.readouterr()
        assert out_text == ""  # no "campaign two: 2 cases on ..." line: nothing started
        assert err == (
            f"pirate-bt: the Dask scheduler at {address} has no workers after 5 s: start"
            f" workers (dask worker {address}), or give a longer --scheduler-timeout\n"
        )
        assert results.read_text() == kept  # no case written as an error
        cluster.scale(1)
        assert main([*resume, "--scheduler", address, "--scheduler-timeout", "60 s"]) == 0
    rows = [json.loads(line) for line in results.read_text().splitlines()]
    assert sorted(row["seed"] for row in rows) == [0, 1]
    assert {row["outcome"] for row in rows} == {"success"}


class RaisesAsMade:
    """A plug-in navigator whose making raises (a bug of its own, not a refusal)."""

    def __init__(self, speed: str = "1") -> None:
        raise RuntimeError(f"no speed {speed}")

    def next_step(self, obs: object) -> None:  # pragma: no cover - never made
        return None


class ExitsAsMade:
    """A plug-in navigator whose making ends the process."""

    def __init__(self, speed: str = "1") -> None:
        sys.exit(0)

    def next_step(self, obs: object) -> None:  # pragma: no cover - never made
        return None


@pytest.mark.parametrize(
    ("made", "said"),
    [
        # was 'pirate-bt: internal error: RuntimeError: no speed 2 (rerun with --debug)'
        (RaisesAsMade, "RuntimeError as it was made: no speed 2 (at "),
        # 'validate' and 'campaign' ended with exit 0, nothing said and nothing run
        (ExitsAsMade, "SystemExit as it was made: 0 (at "),
    ],
    ids=["raises", "exits"],
)
def test_a_navigator_whose_making_raises_is_placed_at_the_run(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    made: type,
    said: str,
) -> None:
    from importlib.metadata import EntryPoint

    from pirate_bt.task import navigators as registry

    plugin = EntryPoint(
        name="rogue", value=f"{__name__}:{made.__name__}", group=registry.ENTRY_POINT_GROUP
    )
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])
    spec = tmp_path / "nav.campaign.yaml"
    run = "  - {name: r, navigator: rogue, network: lab, params: {speed: '2'}}"
    spec.write_text(f"name: rogue\nruns:\n{run}\n")
    out = tmp_path / "out"
    for argv in (["validate", str(spec)], ["campaign", str(spec), "--output", str(out), "-q"]):
        assert main(argv) == 2
        err = capsys.readouterr().err.removeprefix("pirate-bt: ")
        column = run.index("params") + 1
        assert err.startswith(f"{spec}:3:{column}: run 'r': navigator 'rogue' raised {said}")
        assert len(err.splitlines()) == 1
        assert __file__.removesuffix("c") in err  # the place it was raised
    assert not out.exists()


def test_a_navigator_parameter_a_run_lacks_is_asked_for_under_params(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "nav.campaign.yaml"
    spec.write_text("name: nav\nruns:\n  - {name: g, navigator: goal, network: lab}\n")
    assert main(["validate", str(spec)]) == 2
    # said '(--param segment=...; it takes: segment)', the command line's option
    assert capsys.readouterr().err == (
        f"{spec}:3:15: run 'g': navigator 'goal' needs the parameter 'segment'"
        " (params: {segment: ...}; it takes: segment)\n"
    )


@pytest.mark.parametrize(
    ("run", "extra", "named"),
    [
        ("{tree: straight, network: bad.yaml, params: {distance: 0.2 m}}", "", "runs[0].network"),
        ("{route: straight}", "maps: [null, bad.yaml]\n", "maps[1]"),
        ("{tree: straight, params: {distance: 0.2 m}}", "robots: [null, bad.yaml]\n", "robots[1]"),
        ("{route: bad.route}", "", "runs[0].route"),
    ],
    ids=["network", "maps", "robots", "route"],
)
def test_a_named_file_that_does_not_parse_is_told_with_the_spec_entry_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], run: str, extra: str, named: str
) -> None:
    (tmp_path / "bad.yaml").write_text("segments: [\n")  # no network, no robot: no YAML
    (tmp_path / "bad.route").write_text("forward 1 m\nsideways 2 m\n")
    spec = tmp_path / "s.campaign.yaml"
    text = f"name: h\nruns:\n  - {run}\n{extra}"
    spec.write_text(text)
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    # the file's own place first, as before; which entry of the spec named it was not said
    assert err.startswith(str(tmp_path / ("bad.route" if "route" in named else "bad.yaml")))
    line = 3 if named.startswith("runs") else 4  # a run's key, an axis's entry
    at = named.split(".")[-1] if named.startswith("runs") else "bad.yaml"
    column = text.splitlines()[line - 1].index(at) + 1
    assert err.endswith(f" (named by {named} at {spec}:{line}:{column})\n")
    assert len(err.splitlines()) == 1


def test_a_named_file_of_a_spec_given_as_data_is_told_with_its_entry(tmp_path: Path) -> None:
    from pirate_bt import run_campaign
    from pirate_bt.errors import ValidationFailed

    (tmp_path / "bad.yaml").write_text("segments: [\n")
    run = {"tree": "straight", "network": "bad.yaml", "params": {"distance": "0.2 m"}}
    with pytest.raises(ValidationFailed) as refused:
        run_campaign({"name": "h", "runs": [run]}, base=tmp_path)
    # data has no lines: the entry once, not 'runs[0].network at campaign spec: runs[0]...'
    assert str(refused.value).endswith(" (named by campaign spec: runs[0].network)")


class _HugeReason:
    """A navigator whose error says ten megabytes."""

    def next_step(self, obs: object) -> None:
        raise RuntimeError("x" * 10_000_000)


def test_a_case_s_reason_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    from pirate_bt.campaign import campaign_from_data, expand
    from pirate_bt.campaign.case import REASON_LIMIT, run_case
    from pirate_bt.task import navigators

    monkeypatch.setitem(navigators._BUILT_IN, "huge", _HugeReason)
    spec = campaign_from_data(
        {"name": "h", "runs": [{"navigator": "huge", "network": "straight"}], "max_time": "60 s"}
    )
    (case,) = expand(spec)
    record = run_case(case)
    # a 10 MB row, in results.jsonl and results.csv alike, for each such case
    assert record["outcome"] == "error"
    assert record["reason"].startswith("navigator 'huge' raised RuntimeError: xxx")
    # (the navigation bounds a navigator's message itself now, to 1,000 characters)
    assert len(record["reason"]) <= REASON_LIMIT
    assert len(json.dumps(record)) < 3 * REASON_LIMIT


def test_a_dask_cluster_that_loses_every_worker_stops_and_resume_runs_the_rest(
    tmp_path: Path,
) -> None:
    pytest.importorskip("distributed")
    from distributed import LocalCluster

    from pirate_bt import run_campaign
    from pirate_bt.errors import LinkError

    spec = {
        "name": "lost",
        "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.1 m"}}],
        "seeds": {"count": 6},
        "max_time": "60 s",
    }
    out = tmp_path / "out"
    with LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        dashboard_address=None,
        protocol="tcp://",
        host="127.0.0.1",
    ) as cluster:
        address = cluster.scheduler_address
        seen: list[str] = []

        def lose_the_workers(row: dict[str, object]) -> None:
            seen.append(str(row["id"]))
            if len(seen) == 1:
                cluster.scale(0)  # as a worker killed, the cluster's last

        # it waited for ever for a worker to come back, the cases out neither run nor given back
        with pytest.raises(LinkError) as stopped:
            run_campaign(
                spec, scheduler=address, scheduler_timeout=5, output=out, on_record=lose_the_workers
            )
        message = str(stopped.value)
        assert message.startswith(
            f"the Dask scheduler at {address} has had no workers for 5 s (they were lost);"
        )
        kept = (out / "results.jsonl").read_text().splitlines()
        assert 1 <= len(kept) < 6  # the rows of the cases that ran, whole
        assert message.endswith(
            f"keeps {len(kept)} of its 6 cases: run again with resume=True to run the other"
            f" {6 - len(kept)}"
        )
        cluster.scale(1)
        result = run_campaign(
            spec, scheduler=address, scheduler_timeout=60, output=out, resume=True
        )
    assert result.summary() == "6 runs: 6 success, 0 failed safe, 0 error, 0 timeout"
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert sorted(row["seed"] for row in rows) == list(range(6))

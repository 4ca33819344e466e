"""Session 21, a campaign's leftovers: messages in a spec's words (its file, line,
column and keys), a Dask cluster with no workers."""

from __future__ import annotations

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

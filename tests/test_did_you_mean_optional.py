"""An unknown key close to a key the file may hold at that place says which: ``seed:``
for a campaign's ``seeds:``, ``distanse:`` for a drive's ``distance:``, ``lenght:``
in a network's straight. Until 2026-11-30 only a key close to a *missing required*
key got the hint, so a misspelt optional key was a bare *unknown key*."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("name", "text", "said"),
    [
        (
            "c.campaign.yaml",
            "name: c\nruns:\n  - {tree: straight, params: {distance: 0.2 m}}\nseed: {count: 2}\n",
            ":4:1: unknown key 'seed' (did you mean 'seeds'?)",
        ),
        (
            "d.campaign.yaml",
            "name: d\nruns:\n  - {tree: straight, params: {distance: 0.2 m}}\n"
            "link: {drops: [0.1]}\n",
            ":4:8: unknown key 'drops' (did you mean 'drop'?)",
        ),
        (
            "t.yaml",
            "name: t\nroot:\n  type: drive\n  velocity: 10 mm/s\n  distanse: 5 mm\n",
            ":5:3: drive: unknown key 'distanse' (did you mean 'distance'?)",
        ),
        (
            "n.yaml",
            "name: n\ndiameter: 63 mm\nsegments:\n  - {type: straight, lenght: 2 m}\n",
            ":4:22: unknown key 'lenght' (did you mean 'length'?)",
        ),
    ],
)
def test_a_misspelt_optional_key_names_the_key_meant(
    name: str, text: str, said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / name
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err.strip() == f"{path}{said}"


@pytest.mark.parametrize(
    "text",
    [
        # nothing close
        "name: t\nroot:\n  type: drive\n  velocity: 10 mm/s\n  zzz: 5 mm\n",
        # the key it is close to is written beside it already
        "name: t\nroot:\n  type: drive\n  velocity: 10 mm/s\n  distance: 5 mm\n  distanse: 5 mm\n",
    ],
)
def test_no_hint_where_no_key_stands_out(
    text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "unknown key" in err and "did you mean" not in err, err

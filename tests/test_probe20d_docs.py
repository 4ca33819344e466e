"""Probe 20d: a new user runs what the manual shows and compares what comes back.

Findings, each pinned below:

- docs/campaigns.md, *Navigators*: a ``route`` navigator whose route names another
  network was quoted as refused with *the route '.../t-joint.route' names network
  't-joint' ..., not 'lab'*; for ``t-joint.route`` on ``lab`` ``validate`` says that
  its route does not fit the map, naming the network it was written for. The other
  line is said for a route that would fit. The page now quotes both, each for its run.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pirate_bt.cli import main

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"


def _quoted(page: Path, start: str) -> str:
    """The backquoted text on ``page`` that starts with ``start``, its lines joined."""
    text = re.sub(r"\s*\n\s*", " ", page.read_text(encoding="utf-8"))
    found = re.findall("`(" + re.escape(start) + "[^`]*)`", text)
    assert len(found) == 1, f"{page.name}: {len(found)} quotes start {start!r}"
    return str(found[0])


def _as_pattern(quote: str) -> str:
    """A quoted message as a regex: ``...`` stands for any text (a path, a list)."""
    return ".*".join(re.escape(part) for part in quote.split("..."))


def _validate(tmp: Path, name: str, text: str, capsys: pytest.CaptureFixture[str]) -> str:
    (tmp / name).write_text(text, encoding="utf-8")
    assert main(["validate", name]) == 2
    return capsys.readouterr().err.strip()


@pytest.mark.parametrize(
    ("start", "route"),
    [
        # before: the page quoted the network-line refusal for this run
        ("nav.campaign.yaml:3:33: run 'r': navigator 'route'", "t-joint.route"),
        ("run 'r': the route '.../s.route'", "s.route"),
    ],
)
def test_the_campaign_pages_route_navigator_refusals_are_what_validate_prints(
    start: str,
    route: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    quote = _quoted(DOCS / "campaigns.md", start)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.route").write_text("network straight\nforward 1 m\n", encoding="utf-8")
    spec = (
        "name: nav\nruns:\n"
        f"  - {{name: r, navigator: route, network: lab, params: {{route: {route}}}}}\n"
    )
    printed = _validate(tmp_path, "nav.campaign.yaml", spec, capsys)
    assert re.search(_as_pattern(quote), printed), f"docs: {quote}\nprinted: {printed}"

"""Probe 20d: a new user runs what the manual shows and compares what comes back.

Findings, each pinned below:

- docs/campaigns.md, *Navigators*: a ``route`` navigator whose route names another
  network was quoted as refused with *the route '.../t-joint.route' names network
  't-joint' ..., not 'lab'*; for ``t-joint.route`` on ``lab`` ``validate`` says that
  its route does not fit the map, naming the network it was written for. The other
  line is said for a route that would fit. The page now quotes both, each for its run.
- docs/interop.md said an XML tree's ``validate``, ``run`` and ``import`` report every
  problem at its XML element; the conversion stops at its first (an unknown node type,
  a port, a value of the wrong dimension), so ``<Fly/>`` beside a ``torque="50 N*m"``
  said only the first, where the same YAML tree says both. The page now says so; the
  loader's checks of the converted tree (limits, duplicate names) are said all at once.
  The code is out of this probe's scope (reported).
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


_XML = """<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4" main_tree_to_execute="t">
  <BehaviorTree ID="t">
    <Sequence name="s">
{nodes}
    </Sequence>
  </BehaviorTree>
</root>
"""


def test_an_xml_tree_says_its_first_conversion_problem_and_every_loader_problem(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: "report every problem at its XML element"; a second problem of the
    # conversion was not said
    text = re.sub(r"\s+", " ", (DOCS / "interop.md").read_text(encoding="utf-8"))
    assert "The conversion stops at the first problem of its own" in text
    assert "is said all at once, as for a YAML tree" in text
    monkeypatch.chdir(tmp_path)
    clamp = '      <clamp half="front" torque="50 N*m"/>'
    printed = _validate(
        tmp_path, "a.xml", _XML.format(nodes="      <Fly/>\n" + clamp), capsys
    ).splitlines()
    assert printed == ["a.xml:5:7: unknown node type 'Fly'"]
    loader = clamp + '\n      <clamp half="rear" torque="60 N*m"/>'
    printed = _validate(tmp_path, "b.xml", _XML.format(nodes=loader), capsys).splitlines()
    assert [line.split(": torque")[0] for line in printed] == [
        "b.xml:5:7: clamp",
        "b.xml:6:7: clamp",
    ]

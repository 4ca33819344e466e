"""Probe 17: a new user follows the manual as written (README.md, then every page in
mkdocs.yml's order), runs what it shows and compares what comes back.

Findings, each pinned below:

- docs/campaigns.md, *Bad input*: a tree parameter its node refuses was quoted as
  ``drive: Input should be greater than 0`` (pydantic's words); ``pirate-bt validate``
  and ``pirate-bt campaign`` say ``drive: distance: must be more than 0 m, not 0.0 m``.
- docs/networks.md, *Segments*: segments without an id were said to be named
  ``main-1``, ``main-2``, ...; they are named by their place in the line, the segments
  with an id counted too (after ``entry``, a bend without an id is ``main-2``).
- docs/installation.md said bundled files are found by name from any folder, and
  docs/campaigns.md that a spec's relative names fall back on the bundled files: both
  hold for trees, networks and routes, not for robots (``--robot pirate.yaml`` and a
  campaign's ``robots: [hardware/pirate.yaml]`` outside the repository are *no such
  file*). Both pages now say a robot is a path and ``null``/no option the bundled one.
- docs/networks.md's and docs/routes.md's tables of bundled files left out
  ``lab-long.yaml`` and ``service-tees.yaml``, and ``lab-long.route``, which every
  *bundled networks: ...* error names.
- docs/routes.md, *When the route is wrong*: the errors of a ``bad.route`` it never
  showed, with ``bad.route:3:11`` for ``forward 2`` (the column is 10, where the unit
  goes); the page now shows the file and what ``validate`` prints for it.
- docs/console.md, *Scripts and tests*: ``--keys`` always ends with a line of the state
  the keys left (``--keys '?'`` prints it twice); the page said only that ``?`` prints
  it. It now says so and shows ``teleop --keys f`` with its output.
- docs/missions.md, *The demo*: the table of what ``demo-output/`` holds left out
  ``coverage.svg`` (and the ``.dot`` sources), which the demo and ``mission --output``
  write.
- docs/performance.md gave the firmware sizes of 2026-11-29 (bridge 8966 B, PICO
  8152 B, 24.9 %); ``make firmware`` prints 8970 B and 8216 B (25.1 %), as
  docs/firmware.md shows.
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
    ("start", "spec"),
    [
        (  # a value the tree's drive refuses, placed at the value under the run's params
            "h.campaign.yaml:4:14: parameter 'distance'",
            "name: h\nruns:\n  - name: s\n    params: {distance: 0 m}\n"
            "    tree: straight\n    network: straight\n",
        ),
        (  # a parameter without a default that the run leaves out, placed at its params
            "h.campaign.yaml:4:33: run 'two'",
            "name: h\nruns:\n"
            "  - {name: one, tree: straight, network: straight, params: {distance: 1 m}}\n"
            "  - {name: two, tree: straight, params: {velocity: 50 mm/s}}\n",
        ),
    ],
)
def test_the_campaign_pages_parameter_errors_are_what_validate_prints(
    start: str,
    spec: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # before: the page quoted "drive: Input should be greater than 0" for the first
    quote = _quoted(DOCS / "campaigns.md", start)
    monkeypatch.chdir(tmp_path)
    printed = _validate(tmp_path, "h.campaign.yaml", spec, capsys)
    assert re.fullmatch(_as_pattern(quote), printed), f"docs: {quote}\nprinted: {printed}"


def test_a_segment_without_an_id_is_named_as_the_networks_page_says(tmp_path: Path) -> None:
    # before: "named main-1, main-2, ...": the first segment without an id after
    # `entry` was taken for main-1; it is main-2 (its place in the line)
    from pirate_bt.pipes import load_network

    text = re.sub(r"\s*\n\s*", " ", (DOCS / "networks.md").read_text(encoding="utf-8"))
    match = re.search(r"`(segments: \[[^`]+\])` names the bend `([^`]+)`", text)
    assert match is not None, "networks.md: no example of a segment named by its place"
    network = tmp_path / "n.yaml"
    network.write_text(f"name: n\ndiameter: 63 mm\n{match[1]}\n", encoding="utf-8")
    path = load_network(network).main_path()
    assert [piece.segment for piece in path.pieces if piece.kind == "bend"] == [match[2]]


def test_a_robot_named_as_a_bundled_file_is_refused_as_the_installation_page_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: "bundled files are found by name from any folder", robots included by
    # its words; --robot takes a path only
    text = re.sub(r"\s*\n\s*", " ", (DOCS / "installation.md").read_text(encoding="utf-8"))
    match = re.search(r"`pirate-bt (run straight --robot pirate\.yaml)` says \*([^*]+)\*", text)
    assert match is not None, "installation.md: no word on --robot and bundled names"
    monkeypatch.chdir(tmp_path)
    assert main([*match[1].split(), "--param", "distance=0.1m", "-q"]) == 2
    assert capsys.readouterr().err.strip() == f"pirate-bt: {match[2]}"


def test_a_campaigns_robot_is_a_path_not_a_bundled_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # campaigns.md said every relative name falls back on the bundled files
    text = re.sub(r"\s*\n\s*", " ", (DOCS / "campaigns.md").read_text(encoding="utf-8"))
    assert "Robots have no bundled names" in text
    monkeypatch.chdir(tmp_path)
    spec = (
        "name: c\nruns:\n"
        "  - {name: a, tree: straight, network: straight, params: {distance: 1 m}}\n"
        "robots: [hardware/pirate.yaml]\n"
    )
    printed = _validate(tmp_path, "c.campaign.yaml", spec, capsys)
    assert printed == "c.campaign.yaml:4:10: robot 'hardware/pirate.yaml': no such file"


@pytest.mark.parametrize(
    ("page", "heading", "suffix"),
    [
        ("networks.md", "## Bundled scenarios", ".yaml"),
        ("routes.md", "## Bundled routes", ".route"),
    ],
)
def test_the_bundled_tables_list_every_bundled_file(page: str, heading: str, suffix: str) -> None:
    # before: lab-long and service-tees (networks), lab-long (routes) were bundled, named
    # by every "bundled networks: ..." error, and missing from the tables
    from pirate_bt.resources import bundled_names

    text = (DOCS / page).read_text(encoding="utf-8")
    section = text[text.index(heading) :].split("\n## ", 1)[0]
    listed = set(re.findall(r"`([\w-]+)" + re.escape(suffix) + "`", section))
    missing = sorted(set(bundled_names("scenarios", suffix)) - listed)
    assert not missing, f"docs/{page}, {heading}: no row for {missing}"


def test_the_routes_pages_bad_route_gives_the_lines_it_shows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: the page showed 'bad.route:3:11' for `forward 2` (it is 3:10) and not the
    # file, so nobody could reproduce it
    text = (DOCS / "routes.md").read_text(encoding="utf-8")
    block = re.search(
        r"^\$ cat bad\.route\n(.*?)^\$ pirate-bt validate bad\.route\n(.*?)^```", text, re.S | re.M
    )
    assert block is not None, "routes.md: no bad.route with its validate output"
    monkeypatch.chdir(tmp_path)
    printed = _validate(tmp_path, "bad.route", block[1], capsys)
    assert printed.splitlines() == block[2].splitlines()


def test_the_consoles_keys_example_prints_what_the_page_shows(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # before: the page said `?` prints the state, not that the last line always is
    text = (DOCS / "console.md").read_text(encoding="utf-8")
    block = re.search(r"^\$ pirate-bt (teleop --keys \S+)\n(.*?)^```", text, re.S | re.M)
    assert block is not None, "console.md: no --keys example with its output"
    assert main(block[1].split()) == 0
    assert capsys.readouterr().out.splitlines() == block[2].splitlines()


def test_the_demos_table_names_every_file_a_missions_output_holds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: missions.md's table of demo-output/ left out coverage.svg
    text = (DOCS / "missions.md").read_text(encoding="utf-8")
    section = text[text.index("## The demo") :].split("\n## ", 1)[0]
    table = set(re.findall(r"^\| `([\w.]+)`(?:, `([\w.]+)`)? \|", section, re.M))
    named = {name for row in table for name in row if name}
    monkeypatch.chdir(tmp_path)
    (tmp_path / "short.route").write_text("network straight\nforward 0.3 m\n", encoding="utf-8")
    assert main(["mission", "short.route", "--output", "out", "-q"]) == 0
    capsys.readouterr()
    written = {p.name for p in (tmp_path / "out").iterdir() if p.suffix != ".dot"}
    assert written <= named, f"missions.md's demo table leaves out {sorted(written - named)}"
    assert "robot.svg" in named
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    demo = readme[readme.index("## What `make demo` does") :].split("\n## ", 1)[0]
    assert "coverage" in demo, "README.md: what make demo does leaves out the coverage diagram"


def test_the_performance_pages_firmware_sizes_are_the_firmware_pages() -> None:
    # before: performance.md gave 8966 B and 8152 B (24.9 %), a day old; firmware.md
    # shows what `make firmware` prints (tests/test_probe17_firmware.py builds it)
    firmware = (DOCS / "firmware.md").read_text(encoding="utf-8")
    performance = (DOCS / "performance.md").read_text(encoding="utf-8")
    for elf, chip in (("piratebay", "bridge (ATmega2560)"), ("pico", "PICO (ATmega328p)")):
        printed = re.search(
            rf"^{elf}\.elf: flash (\d+) of \d+ bytes \(([\d.]+) %\), SRAM (\d+) of", firmware, re.M
        )
        assert printed is not None, f"firmware.md: no line for {elf}.elf"
        flash, share, sram = printed.groups()
        row = re.search(
            rf"^\| {re.escape(chip)} flash / static SRAM \| ([^|]+)\|", performance, re.M
        )
        assert row is not None, f"performance.md: no row for the {chip}"
        assert row[1].startswith(f"{flash} B of "), row[1]
        assert f"({share} %) / {sram} B of" in row[1], row[1]
    bridge = re.search(r"^\| flash \(\.text \+ \.data\) \| (\d+) B", performance, re.M)
    assert bridge is not None
    assert re.search(rf"^piratebay\.elf: flash {bridge[1]} of", firmware, re.M), bridge[1]

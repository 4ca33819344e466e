"""Probe 20d, the command-line contract: an output that cannot be written is named by
the file and the option the user typed, never by a library parameter or not at all."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pirate_bt.cli import main

REPO = Path(__file__).resolve().parent.parent

needs_dev_full = pytest.mark.skipif(
    not os.path.exists("/dev/full"), reason="needs /dev/full (a device that is always full)"
)


def _full(tmp_path: Path, name: str) -> Path:
    """``name`` in ``tmp_path``: a link to /dev/full, a file whose every write fails with
    'No space left on device', as a full disk's does."""
    path = tmp_path / name
    path.symlink_to("/dev/full")
    return path


@needs_dev_full
def test_a_header_onto_a_full_disk_names_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = _full(tmp_path, "layout.h")
    assert main(["robot", "header", "-o", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    # was "pirate-bt: No space left on device": which file, of which command?
    assert captured.err.splitlines() == [f"pirate-bt: {out}: No space left on device"]


@needs_dev_full
def test_a_diagram_onto_a_full_disk_is_named_by_its_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = _full(tmp_path, "tree.dot")
    assert main(["render", "straight", "-o", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    # was "out: cannot write ...", render_tree's parameter, no option of the command
    assert captured.err.splitlines() == [
        f"pirate-bt: -o: cannot write '{out}': No space left on device"
    ]


@needs_dev_full
def test_a_trace_export_onto_a_full_disk_is_named_by_its_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("mcap")
    trace = tmp_path / "run.jsonl"
    assert main(["run", "straight", "--param", "distance=0.1m", "--trace", str(trace)]) == 0
    out = _full(tmp_path, "run.mcap")
    capsys.readouterr()
    assert main(["trace", "export", str(trace), "-o", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    # was "out_path: cannot write ...", export_mcap's parameter
    assert captured.err.splitlines() == [
        f"pirate-bt: -o: cannot write {out}: No space left on device"
    ]


def test_a_survey_output_not_named_yaml_is_named_by_its_option(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["survey", "-q", "-o", "net.txt"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    # was "output: net.txt is not ...", the API's parameter, not the -o typed
    assert captured.err.splitlines() == [
        "pirate-bt: -o: net.txt is not a .yaml file name; the surveyed network is written as YAML"
    ]
    assert list(tmp_path.iterdir()) == []


def test_a_trace_plot_that_cannot_be_written_is_named_as_the_belief_plot_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    route = tmp_path / "short.route"
    route.write_text("network straight\nforward 0.2 m\n", encoding="utf-8")
    out = tmp_path / "out"
    (out / "plot.png").mkdir(parents=True)  # no file can be written there
    (out / "belief.png").mkdir()
    assert main(["mission", str(route), "-q", "--output", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    # was "no trace plot: [Errno 21] Is a directory: '.../plot.png'", Python's repr
    assert f"pirate-bt: no trace plot: {out / 'plot.png'}: Is a directory" in err
    assert f"pirate-bt: no belief plot: {out / 'belief.png'}: Is a directory" in err
    assert (out / "report.md").is_file()


def test_a_mission_never_writes_its_report_over_its_own_route(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    route = tmp_path / "report.md"  # a route may be named anything
    text = "network straight\nforward 0.2 m\n"
    route.write_text(text, encoding="utf-8")
    assert main(["mission", str(route), "--output", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # refused before the plan is printed
    # was exit 0, the route replaced by the mission's report
    assert captured.err.splitlines() == [
        f"pirate-bt: --output: {route} is the route file, where the mission writes its"
        " report.md; name another folder"
    ]
    assert route.read_text(encoding="utf-8") == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]


def test_teleop_refuses_a_tree_parameter_with_no_tree(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # was exit 0: the parameter dropped without a word, the robot driven by hand
    assert main(["teleop", "--keys", "q", "--param", "distance=1m"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # nothing played
    assert captured.err.splitlines() == [
        "pirate-bt: --param distance=1m: a tree's parameter; give the tree with --tree"
    ]


def test_a_plan_of_one_pab_says_one_pab(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    route = tmp_path / "short.route"
    route.write_text("network straight\nforward 0.2 m\n", encoding="utf-8")
    assert main(["mission", str(route), "--plan"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    # was "1 PABs", where the mission's own line says "1 PAB"
    assert first == f"route {route} on map straight: 1 PAB, 0.20 m"


@pytest.mark.parametrize(
    ("argv", "verb", "unknown"),
    [
        (["trace", "plot", "t.jsonl", "-o", "p.png", "--start", "2"], "trace plot", "--start 2"),
        (["export", "btcpp", "straight", "bend", "-o", "x.xml"], "export btcpp", "bend"),
        (["network", "perturb", "n.yaml", "--seed", "1", "--bogus"], "network perturb", "--bogus"),
    ],
)
def test_an_unknown_argument_of_an_action_points_at_the_action_s_help(
    argv: list[str],
    verb: str,
    unknown: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    # was "pirate-bt trace: ... (see 'pirate-bt trace --help')", a page that lists
    # none of plot's options
    assert capsys.readouterr().err.splitlines() == [
        f"pirate-bt {verb}: unrecognized arguments: {unknown} (see 'pirate-bt {verb} --help')"
    ]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("before", "after", "message"),
    [
        (
            ["--draw", "boards.svg"],
            [],
            "--draw: 'robot header' draws nothing; run 'pirate-bt robot --draw OUT' on its own",
        ),
        (
            ["--robot", "a.yaml"],
            ["b.yaml"],
            "two robot descriptions (a.yaml by --robot, b.yaml after header): give one",
        ),
    ],
)
def test_robot_header_refuses_what_it_would_drop(
    before: list[str],
    after: list[str],
    message: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from pirate_bt.resources import default_robot_path

    monkeypatch.chdir(tmp_path)
    for name in ("a.yaml", "b.yaml"):
        (tmp_path / name).write_bytes(default_robot_path().read_bytes())
    # was exit 0: the header written, no drawing, or b.yaml's header and a.yaml unread
    assert main(["robot", *before, "header", *after, "-o", "layout.h"]) == 2
    assert capsys.readouterr().err.splitlines() == [f"pirate-bt: {message}"]
    assert not (tmp_path / "layout.h").exists()
    assert not (tmp_path / "boards.svg").exists()


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (
            ["run", "straight", "--param", "distance=0.1m", "-q", "--ros-domain-id", "5"],
            "--ros-domain-id",
        ),
        (["mission", "straight", "--plan", "--ros-namespace=/site"], "--ros-namespace"),
        (["teleop", "--keys", "q", "--ros-domain-id", "3"], "--ros-domain-id"),
    ],
)
def test_a_ros2_option_without_ros2_is_refused(
    argv: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # was exit 0, the option dropped without a word (the API refuses it)
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    verb = argv[0]
    assert captured.err.splitlines() == [
        f"pirate-bt {verb}: {option} is for --ros2: add --ros2 [ENDPOINT] or leave it out"
        f" (see 'pirate-bt {verb} --help')"
    ]


def test_a_scheduler_timeout_with_no_scheduler_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    spec = tmp_path / "tiny.campaign.yaml"
    spec.write_text(
        "name: tiny\nruns:\n  - {name: s, tree: straight, network: straight,"
        " params: {distance: 0.1 m}}\nseeds: {start: 0, count: 1}\n",
        encoding="utf-8",
    )
    # was exit 0: the local pool ran, the option dropped without a word
    assert main(["campaign", str(spec), "-q", "--workers", "1", "--scheduler-timeout", "3 s"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        "pirate-bt: --scheduler-timeout is for --scheduler or --scheduler-file: the local"
        " pool needs no reaching; leave it out"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny.campaign.yaml"]


def test_a_diagram_whose_source_would_replace_the_tree_is_named_by_its_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    from pirate_bt.resources import data_dir

    trees = tmp_path / "trees"
    shutil.copytree(data_dir("trees"), trees)
    tree = trees / "mine.dot"  # a tree file may be named anything
    tree.write_bytes((trees / "straight.yaml").read_bytes())
    before = tree.read_bytes()
    assert main(["render", str(tree), "-o", str(trees / "mine.svg")]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    # was "out: writing ...", render_tree's parameter
    assert captured.err.splitlines() == [
        f"pirate-bt: -o: writing '{tree}' would replace '{tree}', a file being drawn;"
        " nothing written"
    ]
    assert tree.read_bytes() == before


@pytest.mark.parametrize("drawing", ["boards.dot", "boards.svg"])
def test_robot_draw_never_replaces_its_robot_description(
    drawing: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from pirate_bt.resources import default_robot_path

    monkeypatch.chdir(tmp_path)
    robot = tmp_path / "boards.dot"  # a description may be named anything
    robot.write_bytes(default_robot_path().read_bytes())
    before = robot.read_bytes()
    # was exit 0: the description replaced by the drawing (or the .svg's source beside it)
    assert main(["robot", "--robot", "boards.dot", "--draw", drawing]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        "pirate-bt: --draw: boards.dot is the robot description file; name another file"
    ]
    assert robot.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["boards.dot"]


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["run", "straight", "--param", "distance=1m", "-q", "--sim", "nosuch"], "--sim"),
        (["teleop", "--keys", "q", "--sim", "nosuch"], "--sim"),
        (["navigate", "explore", "-q", "--sim", "nosuch"], "--sim"),
        (["navigate", "goal", "-q", "--map", "nosuch", "--param", "segment=x"], "--map"),
        (["survey", "-q", "--sim", "nosuch", "-o", "s.yaml"], "--sim"),
        # the mission too: it said "--sim:1:1: ...", a file's place for an option
        (["mission", str(REPO / "scenarios" / "lab.route"), "-q", "--sim", "nosuch"], "--sim"),
    ],
)
def test_a_network_that_is_not_there_is_named_by_its_option(
    argv: list[str],
    option: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.splitlines()
    # was "network: no network 'nosuch'" (run, teleop), "sim: ..." or "map: ..." (the
    # API's parameters); mission said "--sim:1:1: ..."
    assert len(err) == 1, err
    assert err[0].startswith(f"pirate-bt: {option}: no network 'nosuch'; bundled networks:"), err
    assert list(tmp_path.iterdir()) == []

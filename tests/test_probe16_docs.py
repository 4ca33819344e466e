"""Probe 16: a new user types what the manual shows (README.md, index, installation,
api, trees, pabs, safety, simulator, observability, console, hardware, protocol,
interop, architecture, the robot description reference) and compares.

Findings, each pinned below:

- docs/safety.md, *Getting a supervisor*: the first Python block raised ``NameError:
  name 'robot' is not defined`` (it used ``robot`` and ``clock`` it never made, and
  never said what serves ``socket://127.0.0.1:7777``); it now makes both, closes the
  supervisor, and names ``pirate-bt sim straight --tcp 7777``. Run here against a
  simulator served on TCP.
- docs/installation.md: ``pip install .`` was said to install five packages; it
  installs seven (``textual`` for the console, ``tqdm`` for campaigns). The extras
  other than ``plot`` were not named anywhere on the page. ``make test`` was said to
  run ruff, mypy, pytest and mkdocs: it runs ``lint-imports`` too.
- docs/console.md and docs/trees.md: the usage blocks of ``pirate-bt teleop`` and
  ``pirate-bt run`` left out options ``--help`` lists (``--foxglove``, ``--ros2``,
  ``--groot2``, ``--firmware-chain``, ...).
- (code) ``-o a.svg --output b.svg`` was refused with
  ``(PosixPath('a.svg') and PosixPath('b.svg'))``: Python's repr of a path, where
  ``--seed 1 --seed 2`` says ``(1 and 2)``; now ``(a.svg and b.svg)``.
- (code) a line closed under a run logged one ERROR per drive for every stop sent into
  it (27 lines, the same 9 three times); now one line, once while the link stays lost.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"


def _python_block(page: Path, holding: str) -> str:
    blocks = re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), re.S | re.M)
    found = [block for block in blocks if holding in block]
    assert len(found) == 1, f"{page.name}: {len(found)} Python blocks hold {holding!r}"
    return str(found[0])


def _fenced_after(page: Path, heading: str) -> str:
    """The first fenced block after ``heading`` on ``page``."""
    text = page.read_text(encoding="utf-8")
    start = text.index(heading)
    match = re.search(r"^```[\w-]*\n(.*?)^```", text[start:], re.S | re.M)
    assert match is not None, f"{page.name}: no fenced block after {heading!r}"
    return match[1]


@pytest.mark.xdist_group("real-time")  # the wall clock of a robot: a served simulator
def test_the_safety_pages_getting_a_supervisor_block_runs_on_a_served_simulator() -> None:
    # before: NameError: name 'robot' is not defined (and then 'clock')
    from pirate_bt.robot import load_robot
    from pirate_bt.sim import Simulator
    from pirate_bt.sim.server import SimServer

    code = _python_block(DOCS / "safety.md", 'url="socket://127.0.0.1:7777"')
    with Simulator("straight", load_robot()) as sim:
        server = SimServer(sim)
        host, port = server.open_tcp(0)  # the page's 7777, on a port that is free
        server.start()
        names: dict[str, Any] = {"__name__": "__docs__"}
        try:
            exec(compile(code.replace("7777", str(port)), "docs/safety.md", "exec"), names)
        finally:
            supervisor = names.get("sup")
            if supervisor is not None:
                supervisor.close()
            server.stop()
    assert host == "127.0.0.1"
    assert names["verdict"].ok  # the rear half's clamp passed the checks
    assert sim.counters().commands_executed >= 1  # and reached the simulated bridge


def _pyproject() -> dict[str, Any]:
    return tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))


def _package(requirement: str) -> str:
    return re.split(r"[<>=!~\[; ]", requirement, maxsplit=1)[0]


def test_installation_names_every_package_pip_install_installs() -> None:
    # before: "runtime: py_trees, pyserial, pydantic, PyYAML, graphviz" (no textual, tqdm)
    line = next(
        line
        for line in (DOCS / "installation.md").read_text(encoding="utf-8").splitlines()
        if line.startswith("pip install .  ")
    )
    runtime = [_package(r) for r in _pyproject()["project"]["dependencies"]]
    missing = [name for name in runtime if name.lower() not in line.lower()]
    assert not missing, f"docs/installation.md's `pip install .` leaves out {missing}"


def test_installation_names_every_optional_extra() -> None:
    text = (DOCS / "installation.md").read_text(encoding="utf-8")
    extras = sorted(set(_pyproject()["project"]["optional-dependencies"]) - {"dev"})
    missing = [extra for extra in extras if f"`{extra}`" not in text and f"[{extra}]" not in text]
    assert not missing, f"docs/installation.md does not name the extras {missing}"


def test_installation_lists_every_tool_make_test_runs() -> None:
    # before: lint-imports (make lint's third line) was left out
    makefile = (REPO / "Makefile").read_text(encoding="utf-8")
    test_target = re.search(r"^test:(.*)$", makefile, re.M)
    assert test_target is not None
    tools: list[str] = []
    for target in test_target[1].split():
        body = re.search(rf"^{target}:.*\n((?:\t.*\n)+)", makefile, re.M)
        assert body is not None, target
        tools += re.findall(r"\$\(BIN\)/([\w-]+(?: [\w-]+)?)", body[1])
    text = (DOCS / "installation.md").read_text(encoding="utf-8")
    paragraph = text[text.index("`make test` then runs") :].split("\n\n")[0]
    paragraph = " ".join(paragraph.split())
    assert tools, "no tools found in the Makefile's test target"
    missing = [tool for tool in tools if tool.split()[0] not in paragraph]
    assert not missing, f"`make test` runs {missing}, which the page does not list"
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    said = next(line for line in readme.splitlines() if line.startswith("make test "))
    missing = [tool for tool in tools if tool.split()[0] not in said]
    assert not missing, f"the README's `make test` line leaves out {missing}"


def _options_of(command: str, capsys: pytest.CaptureFixture[str]) -> set[str]:
    assert main([command, "--help"]) == 0
    usage = capsys.readouterr().out.split("\n\n")[0]
    return set(re.findall(r"\[(--[\w-]+)", usage)) - {"--help"}


@pytest.mark.parametrize(
    ("page", "heading", "command"),
    [("console.md", "# The operator console", "teleop"), ("trees.md", "## `pirate-bt run`", "run")],
)
def test_a_usage_block_shows_every_option_of_the_commands_help(
    page: str, heading: str, command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: teleop's block had no --foxglove, --ros2, --groot2; run's no
    # --firmware-chain either
    usage = _fenced_after(DOCS / page, heading)
    missing = sorted(option for option in _options_of(command, capsys) if option not in usage)
    assert not missing, f"docs/{page}: the usage of pirate-bt {command} leaves out {missing}"


def test_an_option_given_twice_names_the_paths_as_typed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # docs/index.md: "`-o a.svg --output b.svg`, is refused in one line (exit 2)"
    assert main(["render", "bend", "-o", str(tmp_path / "a.svg"), "--output", "b.svg"]) == 2
    err = capsys.readouterr().err
    assert f"({tmp_path / 'a.svg'} and b.svg)" in err
    assert "PosixPath" not in err


def test_the_architecture_page_names_every_layer_the_import_rules_name() -> None:
    # before: yamlfile/, yamlvalidate, filekinds and resources, four layers of
    # pyproject's import-linter contract, were in no row of the table
    layers = next(
        contract["layers"]
        for contract in _pyproject()["tool"]["importlinter"]["contracts"]
        if contract["type"] == "layers"
    )
    names = [name.strip() for layer in layers for name in layer.split("|")]
    text = (DOCS / "architecture.md").read_text(encoding="utf-8")
    missing = [name for name in names if f"`{name}`" not in text and f"`{name}/`" not in text]
    assert not missing, f"docs/architecture.md does not place {missing}"


def test_the_hardware_pages_motor_example_validates_on_the_board_it_names(
    tmp_path: Path,
) -> None:
    # before: the example took slot 1, which every board of the bundled robot with a
    # free motor slot already uses: "board 28: motor slot 1 used twice"
    from pirate_bt.robot import load_robot

    snippet = _fenced_after(DOCS / "hardware.md", "## Add a motor")
    robot_yaml = (REPO / "hardware" / "pirate.yaml").read_text(encoding="utf-8")
    board = robot_yaml.index("  - id: 28\n")
    motors = robot_yaml.index("    motors:\n", board) + len("    motors:\n")
    mine = tmp_path / "my-robot.yaml"
    mine.write_text(robot_yaml[:motors] + snippet + robot_yaml[motors:], encoding="utf-8")
    robot = load_robot(mine)
    assert robot.motor("rear_camera_tilt").function.value == "camera_tilt"


@pytest.mark.xdist_group("real-time")  # a simulator served on TCP, stopped under the run
def test_a_line_closed_under_a_run_ends_with_a_closing_stop_the_protocol_page_quotes() -> None:
    # docs/protocol.md's table, "the line cut for good, or closed (EOF)": it quoted only
    # "the closing stop was never acknowledged, nor was the e-stop sent after it"; a
    # line closed at the far end says "was not confirmed (write ... failed ...), and the
    # e-stop sent after it failed (...)"
    import threading

    import pirate_bt
    from pirate_bt.robot import load_robot
    from pirate_bt.sim import Simulator
    from pirate_bt.sim.server import SimServer

    row = next(
        line
        for line in (DOCS / "protocol.md").read_text(encoding="utf-8").splitlines()
        if line.startswith("| the line cut for good, or closed (EOF)")
    )
    quoted = [
        # each form up to its first detail: which read or write failed varies with timing
        re.split(r"\(|\.\.\.", q)[0]
        for q in re.findall(r"\*(the closing stop was [^*]+)\*", row)
    ]
    with Simulator("straight", load_robot()) as sim:
        server = SimServer(sim)
        host, port = server.open_tcp(0)
        server.start()
        stopper = threading.Timer(1.5, server.stop)  # the simulator's process killed
        stopper.start()
        try:
            result = pirate_bt.run_tree(
                "straight",
                port=f"socket://{host}:{port}",
                params={"distance": "1 m"},
                max_time="30 s",
            )
        finally:
            stopper.cancel()
            server.stop()
    assert result.exit_code == 3
    closing = result.why.partition("; then ")[2]
    assert closing, result.why  # the stop on close was not confirmed, and says so
    assert closing.startswith(tuple(quoted)), (closing, quoted)


@pytest.mark.xdist_group("real-time")
def test_a_line_closed_under_a_run_is_not_a_wall_of_the_same_errors(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # README: "every error as one line"; with -q a user saw 32 ERROR lines, 27 of
    # them "could not send the stop of <drive>: ... Broken pipe", repeated
    import threading
    from collections import Counter

    import pirate_bt
    from pirate_bt.robot import load_robot
    from pirate_bt.sim import Simulator
    from pirate_bt.sim.server import SimServer

    with Simulator("straight", load_robot()) as sim:
        server = SimServer(sim)
        host, port = server.open_tcp(0)
        server.start()
        stopper = threading.Timer(1.5, server.stop)
        stopper.start()
        try:
            with caplog.at_level("WARNING", logger="pirate_bt"):
                result = pirate_bt.run_tree(
                    "straight",
                    port=f"socket://{host}:{port}",
                    params={"distance": "1 m"},
                    max_time="30 s",
                )
        finally:
            stopper.cancel()
            server.stop()
    assert result.exit_code == 3
    errors = [r.getMessage() for r in caplog.records if r.levelname == "ERROR"]
    repeated = {message: n for message, n in Counter(errors).items() if n > 1}
    assert not repeated, repeated
    per_drive = [m for m in errors if m.startswith("could not send the stop of ")]
    assert len(per_drive) <= 1, per_drive


def test_the_safety_pages_table_of_checks_names_every_reason_code() -> None:
    # before: a command the link failed to send is refused `link_error`, a Reason no
    # row of docs/safety.md's table named (nor any other line of the page)
    from pirate_bt.safety.verdict import Reason

    text = (DOCS / "safety.md").read_text(encoding="utf-8")
    table = text[text.index("## The checks, in order") :].split("\n\n")[1]
    named = set(re.findall(r"`([a-z_]+)`", table))
    missing = sorted(reason.value for reason in Reason if reason.value not in named)
    assert not missing, f"docs/safety.md's checks table does not name {missing}"

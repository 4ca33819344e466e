"""What a planner reads in the docs works as written.

A planner writes Python against ``import pirate_bt`` from README.md and docs/*.md.
These tests take the docs' own text: every Python block is either run here (and its
printed lines checked where the doc says what they are) or named below with the
reason it cannot run in a test; every dotted ``pirate_bt.NAME`` the docs mention
exists; the options the API reference promises are keywords of the functions it
names. A new Python block in the docs fails here until it is listed.
"""

from __future__ import annotations

import ast
import contextlib
import importlib
import inspect
import io
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

import pirate_bt

pytestmark = pytest.mark.xdist_group("docs_planner")

REPO = Path(__file__).resolve().parent.parent
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]

_FENCE = re.compile(r"^(?P<indent>\s*)```(?P<lang>[\w-]*)\s*$")


@dataclass(frozen=True)
class Block:
    doc: str  # "README.md", "api.md", ...
    line: int  # first line of the code
    code: str

    def __str__(self) -> str:
        return f"{self.doc}:{self.line}"


def python_blocks() -> list[Block]:
    """Every fenced ``python`` block of the README and the manual, dedented."""
    blocks: list[Block] = []
    for path in DOCS:
        lines = path.read_text(encoding="utf-8").splitlines()
        i = 0
        while i < len(lines):
            fence = _FENCE.match(lines[i])
            if fence is None:
                i += 1
                continue
            end = i + 1
            while end < len(lines) and not lines[end].strip().startswith("```"):
                end += 1
            if fence["lang"] in ("python", "py", "pycon"):
                indent = len(fence["indent"])
                code = "\n".join(line[indent:] for line in lines[i + 1 : end])
                blocks.append(Block(path.name, i + 2, code + "\n"))
            i = end + 1
    return blocks


@dataclass(frozen=True)
class Run:
    """A block run here: ``after`` names the block whose names it goes on from (as
    the doc goes on from it), ``prefix`` defines what the doc leaves to the reader,
    ``expect`` are texts the doc's comments say the output holds."""

    prefix: str = ""
    after: str | None = None
    expect: tuple[str, ...] = ()
    check: Callable[[dict[str, Any]], None] | None = None
    """Asserts on the names the block left, where its comments say what they hold."""


@dataclass(frozen=True)
class Skip:
    why: str


STALL_WHY = "stall: bend_3_drive draws 1.50 A at 0 mm/s"


def _stalled_rear_clamp(names: dict[str, Any]) -> None:
    """docs/observability.md's trace queries, as its comments give them."""
    trace, rear = names["trace"], names["rear"]
    assert trace.outcome == "failure" and trace.why.startswith("timeout: not done after 5 s")
    assert trace.nodes("*/hold/clamp rear*") == [
        "straight/pass straight/hold or over an opening/hold/hold/clamp rear",
        "straight/pass straight/hold or over an opening/hold/hold/clamp rear/clamp rear half",
    ]
    assert (trace.node(rear).id, trace.node(rear).type) == ("0.0.1.0.0.0.0", "Clamp")
    assert trace.node("hold/clamp rear").id == "0.0.1.0.0.0"  # the tail and the id the text gives
    assert [(c.tick, c.status) for c in trace.statuses(rear)[:2]] == [
        (1, "RUNNING"),
        (102, "FAILURE"),
    ]
    assert trace.status_at(rear, 150) == "RUNNING"
    assert trace.first_tick(rear, "FAILURE") == 102
    assert trace.feedback(rear)[-1].message.startswith("timeout: not done after 5 s")
    first = names["first"]
    assert (first.tick, first.path) == (102, trace.nodes("*/hold/clamp rear*")[1])
    assert first.feedback.startswith("timeout: not done after 5 s (clamping rear: bend_3 0.0°")


def _route_distance(names: dict[str, Any]) -> None:
    assert names["route"].steps[0].distance_m == 2.5


WHERE = "bend/pass bend/confirm enter/front into turn"

# (doc, a text only that block holds) -> what to do with it
BLOCKS: dict[tuple[str, str], Run | Skip] = {
    (
        "README.md",
        'faults="motor_stall:bend_3_drive@5s+20s")\nprint(result.status, result.why)',
    ): Run(expect=(f"failure {STALL_WHY}", WHERE)),
    ("README.md", "mission.counters.violations"): Run(expect=("success mission completed",)),
    ("api.md", "print(result.status)        # failure"): Run(
        expect=("failure\n", f"{STALL_WHY} for 0.55 s (commanded 80 mm/s)", WHERE)
    ),
    ("api.md", "pab.label, pab.kind, pab.outcome"): Run(
        expect=("03 bend right (bend) (line 5) bend success",)
    ),
    ("api.md", "logging.basicConfig"): Skip("it configures the test process's logging"),
    ("api.md", "runner.add_post_tick(lambda info"): Run(
        expect=("runner: success tree succeeded after 107 ticks\n", "success 111 111\n")
    ),
    ("api.md", "mission.failed_pab.label"): Run(
        prefix="import pirate_bt",
        expect=(f"failure {STALL_WHY}", "03 bend right (bend) (line 5)\n", "True 1\n"),
    ),
    # the doc's mission with fixes: the README's bend-right mission has one
    ("api.md", "for fix in mission.fixes"): Run(
        after="README.md:mission.counters.violations", expect=("bend ", " m ", "confidence 1.00")
    ),
    ("campaigns.md", "SLURMCluster"): Skip("needs a Slurm cluster and waits for Enter"),
    ("campaigns.md", '"name": "smoke"'): Skip(
        "starts worker processes (2.5 s); tests/test_campaign_api.py runs the same mapping"
    ),
    ("campaigns.md", "spec,                      # path | mapping"): Skip(
        "a signature, not code: test_run_campaign_signature_is_as_listed checks it"
    ),
    ("firmware-sim.md", "firmware=True)"): Skip(
        "the firmware chain in simavr: minutes of wall time (tests/test_firmware_chain.py)"
    ),
    ("firmware-sim.md", "FirmwareChain("): Skip("a fragment (motors), and simavr"),
    ("index.md", "robot.bend_modules(Half.FRONT)"): Run(
        expect=("['bend_1_joint', 'bend_2_joint']",)
    ),
    ("installation.md", "default_robot_path()"): Run(expect=("pirate.yaml", "'pirate.yaml'")),
    ("interop-foxglove.md", 'FoxgloveServer("127.0.0.1", 8765)'): Skip(
        "three runs in real time on a fixed port; test_simulate_tree_serves_foxglove runs one"
    ),
    ("interop-groot2.md", 'Groot2Server("127.0.0.1", 1667)'): Skip(
        "three runs in real time on Groot2's fixed port (tests/test_groot2.py)"
    ),
    ("interop-groot2.md", "pirate_bt.attach_groot2(runner"): Skip(
        "binds Groot2's fixed port 1667 (tests/test_groot2.py attaches to a runner)"
    ),
    ("interop-groot2.md", "result.coverage.summary()"): Skip(
        "the lab mission, 4 s (tests/test_coverage.py reads mission coverage)"
    ),
    ("missions.md", "perturb_network(drawing.spec, seed=3)"): Skip(
        "the lab mission on an as-built variant, 6 s (tests/test_mission_asbuilt.py)"
    ),
    ("navigators.md", "class ThreeMetres"): Run(
        expect=("navigator ThreeMetres: SUCCESS - navigator 'ThreeMetres' is done after 3 steps (",)
    ),
    ("navigators.md", 'params={"segment": "run-d"})'): Skip(
        "the goal navigator on the lab, 3 s (tests/test_navigate.py runs it)"
    ),
    ("navigators.md", "class RandomExplorer"): Skip(
        "examples/random_explorer.py, run and checked by tests/test_examples.py"
    ),
    ("networks.md", "net.main_path()"): Run(expect=("{'tee-1': 'branch'} 13.48",)),
    ("observability.md", 'TraceRecorder("run.jsonl", tree'): Skip(
        "a fragment: root, clock, robot and port are the reader's"
    ),
    ("observability.md", "attach_trace(\n"): Skip(
        "a fragment: loaded_tree, clock, port, verdicts and args are the reader's"
    ),
    ("observability.md", 'read_trace("stalled.jsonl")'): Run(check=_stalled_rear_clamp),
    ("observability.md", 'render_tree("trees/straight.yaml", "straight.svg"'): Run(
        prefix=(
            "import pirate_bt\n"
            "pirate_bt.simulate_tree('straight', params={'distance': '0.5 m'}, trace='run.jsonl')"
        )
    ),
    ("protocol.md", "RawFrameDecoder(codec)"): Skip("a fragment: robot, received and port"),
    ("routes.md", "parse_route("): Run(check=_route_distance),
    ("safety.md", 'url="socket://127.0.0.1:7777"'): Skip("needs a bridge on a TCP port"),
    ("safety.md", 'open_supervisor(network="riser", seed=3)'): Run(
        prefix="from pirate_bt.safety.factory import open_supervisor"
    ),
    ("simulator.md", "SensorNoise.typical()"): Run(),
    ("trees.md", 'load_tree("trees/examples/patrol.yaml"'): Run(),
    ("trees.md", "Timeout.build("): Run(
        prefix="from pirate_bt.clock import SimClock\nclock = SimClock()"
    ),
}


def _entry(block: Block) -> tuple[str, Run | Skip]:
    keys = [key for key in BLOCKS if key[0] == block.doc and key[1] in block.code]
    assert len(keys) == 1, (
        f"{block}: {'no' if not keys else 'more than one'} entry of BLOCKS matches this"
        f" Python block; say whether it runs (Run) or why not (Skip):\n{block.code}"
    )
    return f"{keys[0][0]}:{keys[0][1]}", BLOCKS[keys[0]]


ALL_BLOCKS = python_blocks()


def test_every_python_block_of_the_docs_is_listed() -> None:
    used = {_entry(block)[0] for block in ALL_BLOCKS}
    stale = sorted(f"{doc}:{text}" for doc, text in BLOCKS if f"{doc}:{text}" not in used)
    assert not stale, f"entries of BLOCKS that match no Python block any more: {stale}"


@pytest.fixture
def in_a_scratch_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder that looks like the repository root to the docs' relative paths, so
    what a block writes lands in the temporary folder."""
    for name in ("scenarios", "trees", "hardware"):
        (tmp_path / name).symlink_to(REPO / name, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    # README.md and api.md run the same mission: simulate it once (same arguments,
    # same result: a run is a function of its inputs)
    simulate_mission = pirate_bt.simulate_mission

    def once(*args: Any, **kwargs: Any) -> Any:
        key = repr((args, sorted(kwargs.items())))
        if key not in _MISSIONS:
            _MISSIONS[key] = simulate_mission(*args, **kwargs)
        return _MISSIONS[key]

    monkeypatch.setattr(pirate_bt, "simulate_mission", once)
    return tmp_path


_MISSIONS: dict[str, Any] = {}


_NAMESPACES: dict[str, dict[str, Any]] = {}
"""The names each block left, for a block that goes on from it (one worker runs this
file: ``xdist_group``)."""


def _run(block: Block) -> str:
    key, entry = _entry(block)
    assert isinstance(entry, Run)
    namespace: dict[str, Any] = {"__name__": "__docs__"}
    if entry.after is not None:
        if entry.after not in _NAMESPACES:
            _run(next(b for b in ALL_BLOCKS if _entry(b)[0] == entry.after))
        namespace = _NAMESPACES[entry.after]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        if entry.prefix:
            exec(compile(entry.prefix, f"<prefix of {block}>", "exec"), namespace)
        exec(compile(block.code, str(block), "exec"), namespace)
    _NAMESPACES[key] = namespace
    supervisor = namespace.get("sup")  # safety.md's simulated robot: closed as the doc says
    if supervisor is not None:
        supervisor.close()
    return out.getvalue()


RUNNABLE = [b for b in ALL_BLOCKS if isinstance(_entry(b)[1], Run)]


@pytest.mark.parametrize("block", RUNNABLE, ids=str)
def test_a_python_block_of_the_docs_runs_as_written(
    block: Block, in_a_scratch_folder: Path
) -> None:
    output = _run(block)
    entry = _entry(block)[1]
    assert isinstance(entry, Run)
    for text in entry.expect:
        assert text in output, f"{block}: the doc says the output holds {text!r}:\n{output}"
    if entry.check is not None:
        entry.check(_NAMESPACES[_entry(block)[0]])


def test_every_pirate_bt_name_the_docs_mention_exists() -> None:
    """``pirate_bt.simulate_tree``, ``pirate_bt.task.localise.SEQUENCE_FRACTION``, ...: a
    dotted name in the docs is a module or an attribute a planner can reach."""
    not_names = {
        "pirate_bt.NAME",  # the reference's placeholder
        "pirate_bt.navigators",  # entry-point groups
        "pirate_bt.nodes",
        "pirate_bt.trees",
        "pirate_bt.trace_formats",
    }
    missing: list[str] = []
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        for match in re.finditer(r"(?<![\w/.-])pirate_bt((?:\.\w+)+)", text):
            dotted = "pirate_bt" + match[1]
            if dotted in not_names:
                continue
            parts = dotted.split(".")
            for cut in range(len(parts), 0, -1):
                try:
                    obj: Any = importlib.import_module(".".join(parts[:cut]))
                except ImportError:
                    continue
                break
            for part in parts[cut:]:
                if not hasattr(obj, part):
                    missing.append(f"{path.name}: {dotted}")
                    break
                obj = getattr(obj, part)
    assert not missing, missing


def test_the_live_view_options_are_keywords_of_every_run_function() -> None:
    """docs/api.md, *Live views*: ``foxglove=``, ``groot2=`` and ``ros2=`` are options of
    these four; ``simulate_tree`` and ``run_tree`` once had no ``foxglove=``."""
    api = (REPO / "docs" / "api.md").read_text(encoding="utf-8")
    assert "`foxglove=`" in api and "`groot2=`" in api and "`ros2=`" in api
    for function in (
        pirate_bt.simulate_tree,
        pirate_bt.run_tree,
        pirate_bt.simulate_mission,
        pirate_bt.run_mission,
    ):
        keywords = inspect.signature(function).parameters
        for option in ("foxglove", "groot2", "ros2", "ros_domain_id", "ros_namespace"):
            assert option in keywords, f"{function.__name__} has no {option}="
            assert keywords[option].default is None


def test_simulate_tree_serves_foxglove() -> None:
    """``simulate_tree(..., foxglove=server)`` serves the run: a client that connects
    afterwards gets the run's header and the tree, latched."""
    pytest.importorskip("foxglove")
    from foxglove_ws import FoxgloveClient

    from pirate_bt.interop.foxglove_live import FoxgloveServer

    with FoxgloveServer("127.0.0.1", 0) as server:
        result = pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, foxglove=server)
        assert result.succeeded
        assert server.enabled, server.failure  # the caller's server stays open
        client = FoxgloveClient("127.0.0.1", server.port)
        try:
            assert client.wait_for(lambda c: "/pirate/run" in c.channels, 10)
            client.subscribe("/pirate/run", "/pirate/tree")
            assert client.wait_for(lambda _: server.subscriptions >= 2, 10)
            server.publish_record({"type": "tick", "n": 10_000, "t_s": 1.0})
            assert client.wait_for(lambda c: c.of("/pirate/run") and c.of("/pirate/tree"), 10)
        finally:
            client.close()
    assert client.of("/pirate/run")[0]["format"] == "pirate-bt-trace"
    names = {entry["name"] for entry in client.of("/pirate/tree")[0]["status"]}
    assert "drive straight" in names


def test_run_campaign_signature_is_as_listed() -> None:
    """docs/campaigns.md lists ``run_campaign``'s keywords with their defaults."""
    from pirate_bt.campaign import run_campaign

    block = next(b for b in ALL_BLOCKS if "spec,                      # path" in b.code)
    listed = dict(re.findall(r"^\s+(\w+)=([^,]+),", block.code, flags=re.MULTILINE))
    assert len(listed) >= 10
    parameters = inspect.signature(run_campaign).parameters
    for name, default in listed.items():
        assert name in parameters, f"run_campaign has no {name}="
        assert parameters[name].default == ast.literal_eval(default), name


def test_each_error_class_has_the_exit_code_the_reference_gives() -> None:
    """docs/api.md, *Errors*: 2 input and configuration, 3 link, 1 otherwise."""
    api = (REPO / "docs" / "api.md").read_text(encoding="utf-8")
    assert "(2 input and\nconfiguration, 3 link, 1 otherwise" in api
    expected = {
        pirate_bt.InputError: 2,
        pirate_bt.LocatedError: 2,
        pirate_bt.ValidationFailed: 2,
        pirate_bt.ConfigurationError: 2,
        pirate_bt.LinkError: 3,
        pirate_bt.SafetyError: 1,
        pirate_bt.PirateError: 1,
    }
    assert {cls: cls.exit_code for cls in expected} == expected


def test_every_name_of_the_reference_is_importable_from_the_package() -> None:
    """docs/api.md: "Every name below is importable from the package itself" and is
    headed by its bare name: ``pirate_bt.Trace``, ``pirate_bt.Fix``,
    ``pirate_bt.attach_trace``... (six of them once raised AttributeError)."""
    page = (REPO / "docs" / "api.md").read_text(encoding="utf-8")
    assert "Every name below is importable from the package itself" in page
    for dotted in re.findall(r"^::: ([\w.]+)", page, flags=re.MULTILINE):
        module, name = dotted.rsplit(".", 1)
        assert name in pirate_bt.__all__, f"pirate_bt.{name} ({dotted}) is not exported"
        assert getattr(pirate_bt, name) is getattr(importlib.import_module(module), name)


def _keywords(call_args: str) -> set[str]:
    """The keywords of one call's argument text, outside strings and nested calls."""
    text = re.sub(r"\"[^\"\n]*\"|'[^'\n]*'", '""', call_args)
    text = re.sub(r"#[^\n]*", "", text)
    found: set[str] = set()
    depth = 0
    for token in re.finditer(r"[(\[{)\]}]|(?<![\w.=!<>])(\w+)=(?!=)", text):
        if token[0] in "([{":
            depth += 1
        elif token[0] in ")]}":
            depth -= 1
        elif depth == 0 and token[1]:
            found.add(token[1])
    return found


def test_every_keyword_the_docs_pass_to_the_front_door_exists() -> None:
    """``pirate_bt.simulate_tree(..., foxglove=...)`` in any doc, code or prose: each
    keyword is a parameter of the function (what a planner copies, Python accepts)."""
    unknown: list[str] = []
    calls = 0
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        for match in re.finditer(r"pirate_bt\.(\w+)\(", text):
            function = getattr(pirate_bt, match[1], None)
            if not callable(function) or match[1] not in pirate_bt.__all__:
                continue
            depth, end = 1, match.end()
            while end < len(text) and depth:
                depth += {"(": 1, ")": -1}.get(text[end], 0)
                end += 1
            parameters = inspect.signature(function).parameters
            calls += 1
            for keyword in _keywords(text[match.end() : end - 1]) - set(parameters):
                unknown.append(f"{path.name}: pirate_bt.{match[1]}(..., {keyword}=...)")
    assert calls >= 20
    assert not unknown, unknown

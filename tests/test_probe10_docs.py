"""What a first-time user found trying the manual's commands and snippets (probe 10).

Each test runs what the docs teach (or its natural next variation) and checks
what the user sees: the option an error names, a line printed once, a file
listed, the exception class the API reference promises.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main

REPO = Path(__file__).resolve().parents[1]
LAB = REPO / "scenarios" / "lab.yaml"


def _short_route(folder: Path) -> Path:
    route = folder / "short.route"
    route.write_text("network straight\nforward 0.2 m\n")
    return route


def test_mission_output_that_cannot_be_written_is_named_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # missions.md: `pirate-bt mission my.route --output out/`; a bad DIR was reported
    # as "trace: cannot write in the folder /proc/x", an option the user never gave
    route = _short_route(tmp_path)
    assert main(["mission", str(route), "--output", "/proc/x", "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pirate-bt: --output: cannot write /proc/x")
    assert "trace:" not in err
    a_file = tmp_path / "notes.txt"
    a_file.write_text("mine\n")
    assert main(["mission", str(route), "--output", str(a_file), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"pirate-bt: --output: {a_file} is a file, not a folder; give a folder"
    assert a_file.read_text() == "mine\n"


def test_mission_summary_names_the_node_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # "... drive straight was still running at mission/.../drive straight": the
    # node was named twice, where `pirate-bt run` names it once
    route = tmp_path / "long.route"
    route.write_text("network straight\nforward 3 m\n")
    assert main(["mission", str(route), "--max-time", "3s", "-q"]) == 1
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "was still running" in line
    node = "mission/route/01 straight 3 m (line 2)/pass straight/confirm drive/drive straight"
    assert line.count(node) == 1


def test_mission_output_lists_coverage_dot_when_graphviz_is_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # with no `dot`, tree.dot was listed ("wrote out/tree.dot") but coverage.dot,
    # written beside it, was not
    import pirate_bt.render.files as files

    monkeypatch.setattr(files.shutil, "which", lambda name: None)
    out = tmp_path / "out"
    assert main(["mission", str(_short_route(tmp_path)), "--output", str(out), "-q"]) == 0
    stdout = capsys.readouterr().out
    assert (out / "coverage.dot").exists()
    assert f"wrote {out / 'tree.dot'}" in stdout
    assert f"wrote {out / 'coverage.dot'}" in stdout


def test_a_tick_the_trace_does_not_hold_is_a_value_error(tmp_path: Path) -> None:
    # api.md: a refused value is an ArgumentValueError (an InputError and a
    # ValueError); Trace.frame_at / status_at take "a whole number from 0 to the last
    # tick". An out-of-range tick was a bare InputError, missed by `except ValueError`.
    from pirate_bt.errors import ArgumentValueError
    from pirate_bt.trace import read_trace

    path = tmp_path / "run.jsonl"
    pirate_bt.simulate_tree({"root": {"type": "wait", "duration": "0.2 s"}}, trace=path)
    trace = read_trace(path)
    for call in (
        lambda: trace.frame_at(trace.last_tick + 1),
        lambda: trace.frame_at(-1),
        lambda: trace.status_at("wait", 10**6),
    ):
        with pytest.raises(ValueError, match="no tick") as caught:
            call()
        assert isinstance(caught.value, ArgumentValueError)
        assert isinstance(caught.value, pirate_bt.InputError)


def test_a_network_given_as_a_route_points_at_the_mission_options(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # the hint said "--map or --sim"; `pirate-bt mission` has no --map (it takes
    # --network), and `--map lab` is read there as --map-tolerance
    assert main(["validate", "--kind", "route", str(LAB)]) == 2
    seen = capsys.readouterr()
    assert "a network file goes to --network or --sim (navigate: --map)" in seen.out + seen.err


def test_network_commands_name_an_unknown_network_as_typed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `pirate-bt network perturb nope ...` said ".../scenarios/nope.yaml:1:1: no such
    # file", a path the user never typed; --sim nope lists the bundled networks
    out = tmp_path / "x.yaml"
    assert main(["network", "perturb", "nope", "--seed", "1", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pirate-bt: no network 'nope'; bundled networks: ")
    assert "lab" in err
    assert "scenarios/nope.yaml" not in err
    assert not out.exists()
    assert main(["network", "perturb", "lab", "--seed", "1", "-o", str(out)]) == 0
    assert out.exists()


def test_sim_names_an_unknown_network_as_typed(capsys: pytest.CaptureFixture[str]) -> None:
    # `pirate-bt sim nope` said ".../scenarios/nope.yaml:1:1: no such file", as network
    # perturb did; `run --sim nope` lists the bundled networks
    assert main(["sim", "nope", "--duration", "0.1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pirate-bt: no network 'nope'; bundled networks: ")
    assert "scenarios/nope.yaml" not in err


def test_a_wrong_type_is_named_with_its_article() -> None:
    # "observe: give a function (or None), not a int"
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.simulate_tree("straight", params={"distance": "0.2 m"}, observe=3)
    assert str(caught.value) == "observe: give a function (or None), not an int"
    with pytest.raises(pirate_bt.InputError, match="cannot connect to an int;"):
        pirate_bt.connect(42)


def test_plan_route_without_a_network_names_the_python_argument(tmp_path: Path) -> None:
    # pirate_bt.plan_route told planner code to "give --sim NETWORK"
    route = tmp_path / "nonet.route"
    route.write_text("forward 1 m\n")
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.plan_route(str(route))
    message = str(caught.value)
    assert message.endswith("add a line 'network NAME' or give network=NAME")
    assert "--sim" not in message
    plan = pirate_bt.plan_route(str(route), network="straight")
    assert len(plan.pabs) == 1


def test_log_with_a_misspelt_subsystem_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    # `pirate-bt --log saftey=debug ...` set a level on a logger nothing logs to, and
    # the run went on with no debug output and no word why
    tree = str(REPO / "trees" / "straight.yaml")
    assert main(["--log", "saftey=debug", "validate", tree]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pirate-bt: bad --log 'saftey=debug': no subsystem 'saftey';")
    assert "did you mean 'safety'?" in err
    assert len(err.splitlines()) == 1
    for spec in ("safety=info", "trees=debug", "task.localise=debug", "pirate_bt.link=warning"):
        assert main(["--log", spec, "validate", tree]) == 0, spec


def test_run_takes_q_as_mission_and_validate_do(capsys: pytest.CaptureFixture[str]) -> None:
    # `pirate-bt mission ... -q` and `validate -q` work; `run ... -q` was a usage error
    path = str(REPO / "trees" / "examples" / "patrol.yaml")
    assert main(["run", path, "-q"]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("patrol: SUCCESS")
    assert captured.err == ""


def test_a_missing_or_folder_route_is_worded_as_a_missing_tree(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # "nope.route:1:1: cannot read the route: [Errno 2] No such file or directory:
    # 'nope.route'" (the name twice, Python's errno) where a tree says "no such file"
    missing = tmp_path / "nope.route"
    assert main(["mission", str(missing)]) == 2
    assert capsys.readouterr().err.strip() == f"pirate-bt: {missing}:1:1: no such file"
    folder = tmp_path / "dir.route"
    folder.mkdir()
    assert main(["validate", str(folder)]) == 2
    seen = capsys.readouterr()
    assert f"{folder}:1:1: is a directory, not a file" in seen.out + seen.err
    with pytest.raises(pirate_bt.ValidationFailed, match=r"nope\.route:1:1: no such file$"):
        pirate_bt.load_route(str(missing))


def test_a_route_given_as_a_network_says_a_network_is_a_yaml_file(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # connect()'s target may be "a network file"; a route file there (it exists) was
    # "no network 'scenarios/lab.route'", as if the file were missing. Named from the
    # repository (a long name is cut short in the message, wherever the clone is).
    monkeypatch.chdir(REPO)
    route = "scenarios/lab.route"
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.connect(route)
    assert f"no network {route!r}: a network file ends in .yaml; bundled networks:" in str(
        caught.value
    )
    with pytest.raises(pirate_bt.InputError, match="no network 'nope'; bundled networks:"):
        pirate_bt.simulate_mission(str(REPO / "scenarios" / "straight.route"), truth="nope")


def test_every_wrong_type_reads_an_int() -> None:
    with pytest.raises(pirate_bt.InputError, match=r"not an int$"):
        pirate_bt.write_mission_outputs(5, "o")
    with pytest.raises(pirate_bt.InputError, match=r"not an int$"):
        pirate_bt.simulate_mission(5)
    with pytest.raises(pirate_bt.InputError, match=r"tree: cannot run an int: give"):
        pirate_bt.simulate_tree(5)


def test_a_fault_on_a_motor_the_robot_lacks_leaves_no_mission_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the output (or trace) folder was made, then the fault refused: an empty folder
    # was left behind by a mission that never started (a tree run left none)
    route = str(_short_route(tmp_path))
    out = tmp_path / "out"
    with pytest.raises(pirate_bt.InputError, match="faults: fault motor_stall: unknown motor"):
        pirate_bt.simulate_mission(route, output=out, faults="motor_stall:nope@1s")
    assert not out.exists()
    traces = tmp_path / "traces"
    argv = ["mission", route, "--trace", str(traces / "t.jsonl"), "-q"]
    assert main([*argv, "--faults", "motor_stall:nope@1s"]) == 2
    assert "unknown motor 'nope'" in capsys.readouterr().err
    assert not traces.exists()


def test_an_option_is_taken_only_as_written_in_full(capsys: pytest.CaptureFixture[str]) -> None:
    # `mission lab.route --map lab` was read as --map-tolerance lab: "not a fraction"
    route = str(REPO / "scenarios" / "lab.route")
    assert main(["mission", route, "--map", "lab"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "pirate-bt mission: unrecognized arguments: --map lab (see 'pirate-bt mission --help')"
    )
    assert main(["run", "straight", "--para", "distance=1 m"]) == 2
    assert "unrecognized arguments: --para" in capsys.readouterr().err

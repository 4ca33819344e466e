"""Inputs that passed their checks and then ran for ever, crashed or wrote a bad file (probe 9).

A hostile-input probe on 2026-11-29 found ``pause 1e300 s`` in a route passing
``validate`` and ``mission --plan``, then ``mission`` running for ever (its time limit
is planned from the pauses); ``load_tree(..., params={"attempts": 10**5000})`` raising
a raw ``ValueError`` from the message that was to refuse it (``str()`` of an int over
4300 digits raises); ``network remove`` of a network's only segment and ``network
add-tee ... 1e-300m`` writing a network that failed ``validate``, exit 0; and ``network
perturb br2.yaml -o br2.yaml`` replacing its input.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.campaign.run import case_timeout_s
from pirate_bt.cli import main
from pirate_bt.errors import InputError, ValidationFailed
from pirate_bt.task.route import parse_route

ROOT = Path(__file__).resolve().parent.parent
ONE = (
    "schema_version: 1\nname: one\ndiameter: 63 mm\n"
    "segments:\n  - {id: b, type: bend, direction: up}\n"
)

# -- a route's pause ------------------------------------------------------------------


@pytest.mark.parametrize(
    "line", ["pause 1e300 s", "pause 99999999999999999999 s", "wait 2 h", "pause 61 minutes"]
)
def test_a_pause_over_an_hour_is_refused_at_its_number(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], line: str
) -> None:
    monkeypatch.chdir(tmp_path)
    Path("p.route").write_text(f"network bend-right\n{line}\n")
    assert main(["validate", "p.route"]) == 2
    column = line.index(" ") + 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"p.route:2:{column}: {line.split()[0]}: '")
    assert err.endswith("' must be at most 3600 s (an hour)") and "\n" not in err
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.plan_route("p.route")
    (error,) = caught.value.errors
    assert (error.location.line, error.location.column) == (2, column)
    assert main(["mission", "--plan", "p.route"]) == 2


def test_a_pause_of_an_hour_is_a_pause_and_a_huge_number_is_cut_short() -> None:
    (step,) = parse_route("pause 3600 s\n").steps
    assert step.duration_s == 3600.0
    (step,) = parse_route("wait 1 h\n").steps
    assert step.duration_s == 3600.0
    with pytest.raises(ValidationFailed) as caught:
        parse_route("pause " + "9" * 300 + " s\n", "p.route")
    assert len(str(caught.value)) < 120 and "must be at most 3600 s" in str(caught.value)


@pytest.mark.parametrize("line", ["forward 1e300 m", "inspect 1e300 m slowly", "back 1e300 m"])
def test_a_distance_is_bounded_by_the_network(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], line: str
) -> None:
    # no limit in the parser: the planner refuses a drive longer than the pipe
    monkeypatch.chdir(tmp_path)
    Path("p.route").write_text(f"network bend-right\n{line}\n")
    assert main(["validate", "p.route"]) == 2
    assert capsys.readouterr().err.startswith("p.route:2:1: ")


# -- a huge whole number in a message ---------------------------------------------------


def test_a_case_timeout_of_5001_digits_is_refused_in_one_line() -> None:
    with pytest.raises(InputError, match=r"^case_timeout: a 5001-digit number is too large$"):
        case_timeout_s(10**5000)
    with pytest.raises(InputError, match=r"^case_timeout: a 401-digit number is too large$"):
        case_timeout_s(-(10**400))


def test_a_tree_parameter_of_5001_digits_is_refused_naming_it() -> None:
    with pytest.raises(InputError, match=r"^params: attempts: .*too large") as caught:
        pirate_bt.load_tree(ROOT / "trees/examples/patrol.yaml", params={"attempts": 10**5000})
    assert "\n" not in str(caught.value)
    assert str(caught.value) == "params: attempts: a 5001-digit number is too large"


# -- pirate-bt network: a network that would not validate, an output onto the input ----


def _refused(capsys: pytest.CaptureFixture[str], *words: str) -> str:
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, lines
    assert all(w in lines[0] for w in words), lines[0]
    return lines[0]


def test_removing_the_only_segment_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    Path("one.yaml").write_text(ONE)
    assert main(["network", "remove", "one.yaml", "b", "-o", "rm.yaml"]) == 2
    assert not Path("rm.yaml").exists()
    _refused(capsys, "-o rm.yaml: nothing written", "segments: []", "does not validate")
    assert main(["network", "remove", "one.yaml", "b"]) == 2  # nor to standard output
    _refused(capsys, "standard output: nothing written", "at least 1 item")


def test_a_tee_that_leaves_a_straight_of_0_mm_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["network", "add-tee", "bend-right", "before"]
    assert main([*argv, "1e-300m", "-o", "at.yaml"]) == 2
    assert not Path("at.yaml").exists()
    _refused(capsys, "-o at.yaml: nothing written", "'length: 0.0 mm'", "must be more than 0 mm")
    assert main([*argv, "0.5m", "-o", "at.yaml"]) == 0  # a tee that fits is written
    capsys.readouterr()
    assert main(["validate", "at.yaml"]) == 0


@pytest.mark.parametrize("how", ["same name", "symlink", "hard link"])
@pytest.mark.parametrize(
    "command",
    [
        ["perturb", "IN", "--seed", "1"],
        ["remove", "IN", "bend"],
        ["add-tee", "IN", "before", "0.5m"],
    ],
)
def test_an_output_onto_the_input_network_is_refused_and_the_input_kept(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    how: str,
    command: list[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    drawn = (ROOT / "scenarios" / "bend-right.yaml").read_text()
    Path("br2.yaml").write_text(drawn)
    out = "br2.yaml"
    if how == "symlink":
        os.symlink("br2.yaml", "link.yaml")
        out = "link.yaml"
    elif how == "hard link":
        os.link("br2.yaml", "hard.yaml")
        out = "hard.yaml"
    argv = ["network", *[("br2.yaml" if w == "IN" else w) for w in command], "-o", out]
    assert main(argv) == 2
    _refused(capsys, f"-o: {out} is the input network file; name another file")
    assert Path("br2.yaml").read_text() == drawn
    assert main([*argv[:-1], "other.yaml"]) == 0  # another file is written
    assert Path("br2.yaml").read_text() == drawn and Path("other.yaml").exists()


def test_a_sensor_with_a_zero_step_is_refused_at_its_own_key(tmp_path: Path) -> None:
    # both were one message at the file's first key (8:1, 'schema_version')
    text = (ROOT / "hardware" / "variants" / "pirate-rear-imu.yaml").read_text()
    assert text.count("per_raw: 0.1 mrad") == 2
    bad = tmp_path / "hw.yaml"
    bad.write_text(text.replace("per_raw: 0.1 mrad", "per_raw: 0 mrad"))
    lines = [
        n for n, line in enumerate(bad.read_text().splitlines(), 1) if "per_raw: 0 mrad" in line
    ]
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.load_robot(bad)
    where = [(e.location.line, e.message) for e in caught.value.errors]
    assert where == [(n, "per_raw must be a non-zero finite quantity") for n in lines]


def test_a_network_value_out_of_range_is_told_in_the_file_s_own_unit(tmp_path: Path) -> None:
    # it read 'Input should be less than or equal to 1.5707963277948966', naming no key
    bad = tmp_path / "n.yaml"
    bad.write_text(
        "schema_version: 1\nname: t\ndiameter: 63 mm\nsegments:\n"
        "  - {id: a, type: straight, length: 1 m}\n"
        "  - {id: b, type: bend, direction: up, angle: 180 deg}\n"
        "  - {id: c, type: straight, length: 20 km}\n"
        "  - {id: d, type: straight, length: 1 m, diameter: 30 mm}\n"
    )
    with pytest.raises(ValidationFailed) as caught:
        pirate_bt.load_network(bad)
    assert [(e.location.line, e.message) for e in caught.value.errors] == [
        (6, "angle: must be at most 90 deg, not 180 deg"),
        (7, "length: must be at most 10 km, not 20 km"),
        (8, "diameter: must be at least 40 mm, not 30 mm"),
    ]


@pytest.mark.parametrize(
    ("given", "as_kind", "words"),
    [
        ("trees/straight.yaml", "--robot", "not a robot description: it has none of its keys"),
        ("hardware/pirate.yaml", "--sim", "not a pipe network: it has none of its keys"),
    ],
)
def test_a_file_of_another_kind_is_one_line_saying_so(
    given: str, as_kind: str, words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # a tree given as the robot was one line per missing and unknown key (nine)
    argv = ["run", "straight", "--param", "distance=0.1m", "--quiet", as_kind, str(ROOT / given)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err
    # and what it looks like instead (was "a file of another kind?": probe 16)
    looks = "a behaviour tree (it has 'root')" if as_kind == "--robot" else "a robot description"
    assert f"it looks like {looks}" in err, err

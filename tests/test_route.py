"""The route language: good routes parse to steps; malformed ones name line, column and a fix."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.filekinds import detect_kind, json_schema
from pirate_bt.task.route import StepKind, load_route, parse_route

REPO = Path(__file__).resolve().parent.parent
SHIPPED = sorted((REPO / "scenarios").glob("*.route"))


def test_every_command_parses() -> None:
    route = parse_route(
        """
        # a comment line
        network lab
        forward 2.5 m            # trailing comment
        Forward 250 cm slowly
        then forward 2 metres
        forward to the end
        inspect 1 m slowly
        inspect to the end
        back 50 cm
        at the bend turn up
        at the next bend turn
        at the T-joint go left
        at the tee go straight
        at the T joint turn right
        go to service-1
        go to segment run-b
        pause 2 s
        wait 1 minute
        return to start
        """,
        "demo.route",
    )
    kinds = [s.kind for s in route.steps]
    assert route.name == "demo"
    assert route.network == "lab"
    assert kinds == [
        StepKind.FORWARD,
        StepKind.FORWARD,
        StepKind.FORWARD,
        StepKind.FORWARD,
        StepKind.INSPECT,
        StepKind.INSPECT,
        StepKind.BACK,
        StepKind.BEND,
        StepKind.BEND,
        StepKind.TEE,
        StepKind.TEE,
        StepKind.TEE,
        StepKind.GOTO,
        StepKind.GOTO,
        StepKind.PAUSE,
        StepKind.PAUSE,
        StepKind.RETURN,
    ]
    s = route.steps
    assert s[0].distance_m == pytest.approx(2.5) and s[0].line == 4 and not s[0].slowly
    assert s[1].distance_m == pytest.approx(2.5) and s[1].slowly
    assert s[2].distance_m == pytest.approx(2.0)
    assert s[3].distance_m is None
    assert s[6].distance_m == pytest.approx(0.5)
    assert s[7].direction == "up" and s[8].direction is None
    assert [x.direction for x in s[9:12]] == ["left", "straight", "right"]
    assert s[12].segment == "service-1" and s[13].segment == "run-b"
    assert s[14].duration_s == pytest.approx(2.0) and s[15].duration_s == pytest.approx(60.0)
    assert s[0].text == "forward 2.5 m"
    assert route.to_json()["steps"][0] == {
        "kind": "forward",
        "line": 4,
        "text": "forward 2.5 m",
        "distance_m": 2.5,
    }


# (route text, "line:column", words the message must contain)
MALFORMED = [
    ("forwrad 2 m", "1:1", ["unknown command 'forwrad'", "did you mean 'forward'"]),
    ("forward 2", "1:10", ["needs a unit", "forward 2.5 m"]),
    ("forward 2 s", "1:11", ["a time", "a length is expected"]),
    ("forward 2 meterz", "1:11", ["unknown unit 'meterz'", "did you mean", "meter"]),
    ("forward two m", "1:9", ["'two' is not a number"]),
    ("forward -1 m", "1:9", ["more than zero"]),
    ("forward 2 m quickly", "1:13", ["unexpected 'quickly'", "'slowly'"]),
    ("forward", "1:8", ["needs a length"]),
    ("at the bend turn upp", "1:18", ["unexpected 'upp'", "did you mean 'up'"]),
    ("at the bnd turn up", "1:8", ["unknown feature 'bnd'", "did you mean 'bend'"]),
    ("at the bend trun up", "1:13", ["unexpected 'trun'", "did you mean 'turn'"]),
    ("at the T-joint go sideways", "1:19", ["unexpected 'sideways'", "'straight'"]),
    ("at the T-joint go", "1:18", ["expected 'left' or 'right'"]),
    ("return to stat", "1:11", ["did you mean 'start'"]),
    ("pause 3 m", "1:9", ["a length", "a time is expected"]),
    ("go to", "1:6", ["give a segment's id"]),
    ("network lab\nnetwork lab", "2:1", ["already named"]),
    ("forward 1 m\nnetwork lab", "2:1", ["before the first command"]),
    ("# only a comment\n\n", "1:1", ["no commands"]),
    ("forward 1 m\n  inspct 2 m", "2:3", ["did you mean 'inspect'"]),
    ("back 1 s", "1:8", ["a time"]),
]


@pytest.mark.parametrize(("text", "where", "words"), MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_route_is_located_with_a_suggestion(
    text: str, where: str, words: list[str]
) -> None:
    with pytest.raises(ValidationFailed) as info:
        parse_route(text, "bad.route")
    first = str(info.value.errors[0])
    assert first.startswith(f"bad.route:{where}: "), first
    for word in words:
        assert word in first, first


def test_every_bad_line_is_reported() -> None:
    with pytest.raises(ValidationFailed) as info:
        parse_route("forwrad 1 m\nforward 1 m\nat the bnd turn up\nreturn home\n", "r.route")
    assert [e.location.line for e in info.value.errors] == [1, 3, 4]


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_shipped_routes_validate(path: Path) -> None:
    route = load_route(path)
    assert route.steps and route.network is not None
    assert main(["validate", str(path)]) == 0


def test_validate_detects_routes_by_suffix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.route"
    bad.write_text("forward 2 m\nat the bend turn upp\n")
    assert detect_kind(bad).name == "route"
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:2:18: " in err and "did you mean 'up'" in err


def test_validate_plans_a_route_on_its_network(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "misfit.route"
    bad.write_text("network bend-left\nforward 1 m\nat the bend turn up\n")
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:3:1: " in err and "turns left, not up" in err


def test_unknown_network_is_located(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "nowhere.route"
    bad.write_text("network labb\nforward 1 m\n")
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:1:9: " in err and "no network 'labb'" in err and "lab" in err


def test_a_network_file_in_another_directory_is_found_from_the_route(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Was refused at the parser: "network: give the network's name".
    (tmp_path / "nets").mkdir()
    (tmp_path / "routes").mkdir()
    (tmp_path / "nets" / "site.yaml").write_text(
        (REPO / "scenarios" / "bend-left.yaml").read_text()
    )
    good = tmp_path / "routes" / "site.route"
    good.write_text("network ../nets/site.yaml\nforward 1 m\nat the bend turn left\n")
    assert main(["validate", str(good)]) == 0
    misfit = tmp_path / "routes" / "misfit.route"
    misfit.write_text("network ../nets/site.yaml\nforward 1 m\nat the bend turn up\n")
    assert main(["validate", str(misfit)]) == 2  # planned on that very file
    assert "turns left, not up" in capsys.readouterr().err
    missing = tmp_path / "routes" / "missing.route"
    missing.write_text("network ../nets/gone.yaml\nforward 1 m\n")
    assert main(["validate", str(missing)]) == 2
    assert f"{missing}:1:9: no network '../nets/gone.yaml'" in capsys.readouterr().err


def test_a_network_name_too_long_for_a_file_is_located_and_cut(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Was "pirate-bt: aaaa...aaa.yaml: File name too long", naming a path nobody wrote.
    bad = tmp_path / "longname.route"
    bad.write_text("network " + "a" * 5000 + "\nforward 1 m\n")
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}:1:9: no network 'aaaa") and err.count("\n") == 1
    assert "... (5000 characters); bundled networks: " in err and len(err) < 400


def test_a_byte_order_mark_is_accepted(tmp_path: Path) -> None:
    # Was "unknown command '\ufeffnetwork'".
    path = tmp_path / "bom.route"
    path.write_bytes(b"\xef\xbb\xbfnetwork lab\nforward 1 m\n")
    route = load_route(path)
    assert route.network == "lab" and [s.text for s in route.steps] == ["forward 1 m"]
    assert str(route.network_location) == f"{path}:1:9"
    assert parse_route("\ufeffforward 1 m").steps[0].location.column == 1


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        (b"network lab\nforward 1 m # caf\xe9\n", "2:18: not UTF-8 text (byte 0xe9)"),
        ("network lab\n# é\xa0\n".encode() + b"forward \xff\n", "3:9: not UTF-8 text (byte 0xff)"),
        ("network lab\nforward 1 m\n".encode("utf-16"), "1:1: UTF-16 text; save the file as UTF-8"),
        (b"forward 1 m\x00\n", "1:1: binary file, not route text"),
    ],
    ids=["latin-1", "after-wide-characters", "utf-16", "binary"],
)
def test_text_that_is_not_utf8_is_located_at_the_bad_byte(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], data: bytes, expected: str
) -> None:
    # Was "1:1: cannot read the route: 'utf-8' codec can't decode byte ..." for all of them.
    path = tmp_path / "bad.route"
    path.write_bytes(data)
    with pytest.raises(ValidationFailed) as caught:
        load_route(path)
    assert [str(e) for e in caught.value.errors] == [f"{path}:{expected}"]
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == f"{path}:{expected}\n"


def test_route_schema() -> None:
    schema = json_schema("route")
    assert schema["type"] == "string"
    assert "forward 2.5 m" in schema["examples"]

"""Pipe networks: loading, located errors, paths and geometry."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.errors import ValidationFailed
from pirate_bt.filekinds import detect_kind, json_schema
from pirate_bt.pipes import PieceKind, load_network, network_from_data
from pirate_bt.resources import data_dir

SCENARIOS = sorted(p.stem for p in data_dir("scenarios").glob("*.yaml"))


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "net.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("name", SCENARIOS)
def test_bundled_scenarios_validate(name: str) -> None:
    net = load_network(name)
    assert net.main_path().length_m > 1.0
    for path in net.paths():
        for piece in path.pieces:
            assert 0.051 <= piece.diameter_start_m <= 0.120


def test_required_scenarios_are_shipped() -> None:
    need = {"straight", "bend-up", "bend-down", "bend-left", "bend-right", "t-joint", "riser"}
    assert need <= set(SCENARIOS)


def test_lab_network_is_big_enough() -> None:
    net = load_network("lab")
    assert net.total_length_m() >= 30.0
    assert len(net.tee_ids()) >= 2
    bends = {p.segment for path in net.paths() for p in path.pieces if p.kind is PieceKind.BEND}
    assert len(bends) >= 4


@pytest.mark.parametrize(
    ("name", "end"),
    [
        ("bend-up", (0, 0, 1)),
        ("bend-down", (0, 0, -1)),
        ("bend-left", (0, 1, 0)),
        ("bend-right", (0, -1, 0)),
    ],
)
def test_bend_directions_turn_the_pipe_that_way(name: str, end: tuple[int, int, int]) -> None:
    path = load_network(name).main_path()
    tangent = path.tangent_at(path.length_m)
    assert tangent == pytest.approx(end, abs=1e-9)


def test_riser_is_vertical_and_bend_arc_length() -> None:
    path = load_network("riser").main_path()
    assert math.degrees(path.slope_at(0.5)) == pytest.approx(0.0)
    assert math.degrees(path.slope_at(path.length_m - 0.1)) == pytest.approx(90.0)
    bend = path.pieces[1]
    assert bend.kind is PieceKind.BEND
    assert bend.length_m == pytest.approx(0.09 * math.pi / 2)
    assert math.degrees(path.slope_at((bend.start_m + bend.end_m) / 2)) == pytest.approx(45.0)


def test_tee_paths_and_features() -> None:
    net = load_network("t-joint")
    assert net.tee_ids() == ["tee"]
    paths = {p.choices["tee"]: p for p in net.paths()}
    assert set(paths) == {"straight", "branch"}
    straight = paths["straight"]
    assert straight.segments == ["before", "tee", "after"]
    assert straight.piece_at(2.05).kind is PieceKind.TEE
    branch = paths["branch"]
    assert branch.segments == ["before", "tee", "branch"]
    turn = next(p for p in branch.pieces if p.kind is PieceKind.TEE_TURN)
    assert turn.roll_rad == pytest.approx(-math.pi / 2)
    assert branch.tangent_at(branch.length_m) == pytest.approx((0, 1, 0), abs=1e-9)


def test_slope_and_diameter_at_a_point() -> None:
    net = network_from_data(
        {
            "name": "n",
            "diameter": "63 mm",
            "segments": [
                {"type": "straight", "length": "1 m"},
                {"type": "straight", "length": "1 m", "slope": "10 deg"},
                {"type": "reducer", "diameter": "80 mm", "length": "100 mm"},
                {"type": "straight", "length": "1 m"},
            ],
        }
    )
    path = net.main_path()
    assert path.slope_at(0.5) == pytest.approx(0.0)
    assert math.degrees(path.slope_at(1.5)) == pytest.approx(10.0)
    assert path.diameter_at(0.5) == pytest.approx(0.063)
    assert path.diameter_at(2.05) == pytest.approx(0.0715)
    assert path.diameter_at(2.5) == pytest.approx(0.080)
    assert path.piece_at(2.05).segment == "main-3"
    assert path.next_turn(0.0) is None


def test_errors_are_located(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "name: bad\n"
        "diameter: 63 mm\n"
        "segments:\n"
        "  - {type: straight, length: 2}\n"
        "  - {type: bend, radius: 90 mm}\n"
        "  - {type: elbow, length: 1 m}\n",
    )
    with pytest.raises(ValidationFailed) as info:
        load_network(path)
    text = [str(e) for e in info.value.errors]
    assert any(t.startswith(f"{path}:4:") and "needs a unit" in t for t in text), text
    assert any(t.startswith(f"{path}:5:") and "exactly one of" in t for t in text), text
    assert any(t.startswith(f"{path}:6:") for t in text), text


def test_duplicate_ids_and_unknown_keys_are_located(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "name: bad\n"
        "diameter: 63 mm\n"
        "segments:\n"
        "  - {id: a, type: straight, length: 2 m}\n"
        "  - {id: a, type: straight, length: 2 m, colour: red}\n",
    )
    with pytest.raises(ValidationFailed) as info:
        load_network(path)
    text = [str(e) for e in info.value.errors]
    assert any(t.startswith(f"{path}:5:") and "colour" in t for t in text), text
    path = write(
        tmp_path,
        "name: bad\n"
        "diameter: 63 mm\n"
        "segments:\n"
        "  - {id: a, type: straight, length: 2 m}\n"
        "  - {id: a, type: straight, length: 2 m}\n",
    )
    with pytest.raises(ValidationFailed) as info:
        load_network(path)
    assert str(info.value.errors[0]).startswith(f"{path}:5:")
    assert "duplicate segment id 'a'" in str(info.value)


def test_slope_on_vertical_run_is_refused(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "name: bad\n"
        "diameter: 63 mm\n"
        "segments:\n"
        "  - {type: bend, direction: up}\n"
        "  - {type: straight, length: 1 m, slope: 10 deg}\n",
    )
    with pytest.raises(ValidationFailed, match="vertical run"):
        load_network(path)


def test_file_kind_and_schema() -> None:
    assert detect_kind(data_dir("scenarios") / "lab.yaml").name == "network"
    schema = json_schema("network")
    assert schema["title"] == "pirate_bt pipe network"
    assert "segments" in schema["required"]


def test_cli_validate_and_schema(tmp_path: Path) -> None:
    from pirate_bt.cli import main

    assert main(["validate", str(data_dir("scenarios") / "lab.yaml")]) == 0
    bad = write(tmp_path, "name: x\ndiameter: 63 mm\nsegments:\n  - {type: bend}\n")
    assert main(["validate", "--kind", "network", str(bad)]) == 2
    assert main(["schema", "network"]) == 0

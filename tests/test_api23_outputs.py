"""``write_mission_outputs`` takes a NumPy number for ``wall_s`` and a path for a
picture's file name, as every argument of the API does (docs/api.md): both were
refused, *wall_s: give seconds (a number) or None, not np.float32(2.0)* and *each
item is a (caption, file name) pair, not ('Scan', PosixPath('scan.png'))*.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import pirate_bt

ROUTE = Path(__file__).resolve().parent.parent / "scenarios" / "straight.route"


@pytest.fixture(scope="module")
def mission() -> Any:
    return pirate_bt.simulate_mission(ROUTE)


def test_a_numpy_wall_time_is_written_into_the_report(mission: Any, tmp_path: Path) -> None:
    pirate_bt.write_mission_outputs(mission, tmp_path, wall_s=np.float32(2.0))
    assert "2.0 s wall" in (tmp_path / "report.md").read_text(encoding="utf-8")


def test_a_picture_named_by_a_path_is_linked(mission: Any, tmp_path: Path) -> None:
    (tmp_path / "scan.png").write_bytes(b"")
    pirate_bt.write_mission_outputs(mission, tmp_path, extra_pictures=[("Scan", Path("scan.png"))])
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "Scan" in report and "(scan.png)" in report


def test_a_picture_that_is_no_file_name_is_still_refused(mission: Any, tmp_path: Path) -> None:
    with pytest.raises(pirate_bt.InputError, match="extra_pictures: each item is a"):
        pirate_bt.write_mission_outputs(mission, tmp_path / "out", extra_pictures=[("Scan", 5)])
    assert not (tmp_path / "out").exists()

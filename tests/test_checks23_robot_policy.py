"""Robot policy values that validate as numbers but cannot work (docs/hardware.md).

Until 2026-12-01 a ``motion.over_torque_time`` at or below the 0.1 s the stalled-joint
watch waits validated (a stalled motor is damaged before the watch lets it go), and so
did a ``safety.rate_window`` of a million seconds (one command after a pause may step a
joint or a drive as far as its limit allows over that time: the limit holds nothing);
it is at most ``safety.max_link_silence``, as long as the host trusts what it knows. Each is
refused at its key, naming the field and the range accepted.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.robot.loader import load_robot

_BUNDLED = Path(__file__).resolve().parent.parent / "hardware" / "pirate.yaml"


def _robot(tmp_path: Path, old: str, new: str) -> tuple[Path, int]:
    text = _BUNDLED.read_text(encoding="utf-8")
    assert text.count(old) == 1
    path = tmp_path / "robot.yaml"
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path, text[: text.index(old)].count("\n") + 1


def _validate(path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    code = main(["validate", str(path)])
    return code, capsys.readouterr().err.splitlines()


@pytest.mark.parametrize("value", ["100 ms", "50 ms", "0.1 s"])
def test_an_over_torque_time_the_stall_watch_cannot_beat_is_refused(
    tmp_path: Path, value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path, line = _robot(tmp_path, "over_torque_time: 300 ms", f"over_torque_time: {value}")
    code, errors = _validate(path, capsys)
    assert code == 2 and len(errors) == 1, errors
    assert errors[0].startswith(f"{path}:{line}:3: over_torque_time "), errors
    assert "stalled-joint watch" in errors[0] and errors[0].endswith("give a time above 100 ms")


@pytest.mark.parametrize("value", ["1e6 s", "501 ms"])
def test_a_rate_window_longer_than_the_host_trusts_the_link_is_refused(
    tmp_path: Path, value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path, line = _robot(tmp_path, "rate_window: 100 ms", f"rate_window: {value}")
    code, errors = _validate(path, capsys)
    assert code == 2 and len(errors) == 1, errors
    assert errors[0].startswith(f"{path}:{line}:3: rate_window "), errors
    assert "is longer than safety.max_link_silence 500 ms" in errors[0]
    assert errors[0].endswith("give a window above 0 s and at most 500 ms"), errors


def test_values_inside_the_ranges_and_the_bundled_robots_are_taken(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, _ = _robot(tmp_path, "rate_window: 100 ms", "rate_window: 500 ms")
    text = path.read_text(encoding="utf-8").replace(
        "over_torque_time: 300 ms", "over_torque_time: 120 ms"
    )
    path.write_text(text, encoding="utf-8")
    assert _validate(path, capsys) == (0, [])
    bundled = [_BUNDLED, *sorted((_BUNDLED.parent / "variants").glob("*.yaml"))]
    assert main(["validate", *map(str, bundled)]) == 0, capsys.readouterr().err
    assert load_robot(str(path)).motion.over_torque_time == pytest.approx(0.12)

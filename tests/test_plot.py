"""Plots shaded and labelled by PAB, legible at any mission length, with zoom to the steps."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ArgumentTypeError, InputError
from pirate_bt.render.plot import pab_nodes, plot_series, plot_trace, strip_labels
from pirate_bt.trace import read_trace

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _mission_trace(path: Path, pabs: int = 30, steps_per_pab: int = 3, step_s: float = 2.0) -> Path:
    """A hand-written mission trace: root > route > PAB sequences > confirm steps."""
    nodes: list[dict[str, Any]] = [
        {"id": "0", "name": "mission", "type": "Sequence", "kind": "composite", "parent": None,
         "children": ["0.0"]},
        {"id": "0.0", "name": "route", "type": "Sequence", "kind": "composite", "parent": "0",
         "children": [f"0.0.{p}" for p in range(pabs)]},
    ]  # fmt: skip
    for p in range(pabs):
        pab = f"0.0.{p}"
        nodes.append(
            {"id": pab, "name": f"{p + 1:02d} bend right (line {p + 4})", "type": "Sequence",
             "kind": "composite", "parent": "0.0",
             "children": [f"{pab}.{s}" for s in range(steps_per_pab)]}
        )  # fmt: skip
        for s in range(steps_per_pab):
            nodes.append(
                {"id": f"{pab}.{s}", "name": f"confirm step {s}", "type": "Confirm",
                 "kind": "decorator", "parent": pab, "children": [], "step": True}
            )  # fmt: skip
    header = {"type": "header", "format": "pirate-bt-trace", "version": 1,
              "tree": {"name": "mission lab", "nodes": nodes}, "tick_period_s": 0.05}  # fmt: skip
    records: list[dict[str, Any]] = [header]
    n = 0
    t = 0.0
    for p in range(pabs):
        pab = f"0.0.{p}"
        for s in range(steps_per_pab):
            status = {f"{pab}.{s}": "R"}
            if s == 0:
                status[pab] = "R"
            if s > 0:
                status[f"{pab}.{s - 1}"] = "S"
            for k in range(round(step_s / 0.05)):
                n += 1
                t = round(n * 0.05, 6)
                tick: dict[str, Any] = {"type": "tick", "n": n, "t_s": t,
                                        "state": {"joint_angle_rad.bend_1": 0.01 * (n % 50),
                                                  "drive_velocity_mps.a": 0.08,
                                                  "drive_velocity_mps.b": 0.06}}  # fmt: skip
                if k == 0:
                    tick["status"] = status
                records.append(tick)
        n += 1
        t = round(n * 0.05, 6)
        records.append({"type": "tick", "n": n, "t_s": t,
                        "status": {pab: "S", f"{pab}.{steps_per_pab - 1}": "S"}})  # fmt: skip
    records.append({"type": "end", "n": n, "t_s": t, "outcome": "success"})
    path.write_text("".join(json.dumps(r) + "\n" for r in records))
    return path


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _mission_trace(tmp_path_factory.mktemp("plot") / "mission.jsonl")


def test_pabs_are_the_children_that_hold_the_steps(mission: Path) -> None:
    trace = read_trace(mission)
    pabs = pab_nodes(trace.structure)
    assert len(pabs) == 30
    assert pabs[0].name == "01 bend right (line 4)"
    series = plot_series(trace)
    assert [s.name for s in series.pabs][:2] == ["01 bend right (line 4)", "02 bend right (line 5)"]
    assert len(series.pabs) == 30 and len(series.steps) == 90
    assert series.values["speed"][0] == pytest.approx(0.07)


def test_labels_never_overlap_at_any_mission_length(mission: Path) -> None:
    spans = plot_series(read_trace(mission)).pabs
    for width_px in (300, 1060, 5000):
        px_per_s = width_px / spans[-1].end_s
        labelled = strip_labels(spans, px_per_s)
        for span, label in labelled:
            if label is not None:
                # 0.62 em per character of a 7 pt font at 100 dpi: the label fits its band.
                needed = (len(label) * 0.62 * 7 + 4) * 100 / 72
                assert (span.end_s - span.start_s) * px_per_s >= needed
        if width_px == 5000:
            assert all(label == span.name for span, label in labelled)
        if width_px == 300:
            assert any(label is None or label.isdigit() for _, label in labelled)


def test_zoom_keeps_the_steps_and_clips_the_series(mission: Path) -> None:
    trace = read_trace(mission)
    series = plot_series(trace, 20.0, 40.0)
    assert all(20.0 <= t <= 40.0 for ts in series.times.values() for t in ts)
    assert series.times["joint_angle_rad.bend_1"][0] == 20.0
    assert all(s.start_s >= 20.0 and s.end_s <= 40.0 for s in series.steps + series.pabs)
    assert {s.name for s in series.steps} >= {"confirm step 0", "confirm step 1", "confirm step 2"}
    # The value at the window's start is what it was then, not unknown.
    assert not math.isnan(series.values["joint_angle_rad.bend_1"][0])


def test_plot_cli_whole_and_zoomed(mission: Path, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    whole, zoom = tmp_path / "whole.png", tmp_path / "zoom.png"
    assert main(["trace", "plot", str(mission), "-o", str(whole)]) == 0
    assert main(["trace", "plot", str(mission), "-o", str(zoom), "--from", "10", "--to", "30"]) == 0
    assert whole.read_bytes()[:8] == PNG_MAGIC and zoom.read_bytes()[:8] == PNG_MAGIC
    # The command draws what the API draws for the same window, and the window matters.
    trace = read_trace(mission)
    plot_trace(trace, tmp_path / "api_whole.png")
    plot_trace(trace, tmp_path / "api_zoom.png", start_s=10.0, end_s=30.0)
    assert whole.read_bytes() == (tmp_path / "api_whole.png").read_bytes()
    assert zoom.read_bytes() == (tmp_path / "api_zoom.png").read_bytes()
    assert zoom.read_bytes() != whole.read_bytes()
    plot_trace(trace, tmp_path / "api_other.png", start_s=10.0, end_s=31.0)
    assert zoom.read_bytes() != (tmp_path / "api_other.png").read_bytes()


@pytest.mark.parametrize(("start", "end"), [(30.0, 10.0), (1e6, None), (-1.0, 5.0)])
def test_a_bad_window_is_bad_input(
    mission: Path, tmp_path: Path, start: float, end: float | None
) -> None:
    with pytest.raises(InputError):
        plot_trace(read_trace(mission), tmp_path / "x.png", start_s=start, end_s=end)
    assert not (tmp_path / "x.png").exists()
    args = ["trace", "plot", str(mission), "-o", str(tmp_path / "y.png"), "--from", str(start)]
    if end is not None:
        args += ["--to", str(end)]
    assert main(args) == 2


def test_plot_trace_takes_a_trace_file_and_refuses_what_is_neither(
    mission: Path, tmp_path: Path
) -> None:
    # a planner script gave the trace's path (docs probe 12): AttributeError from inside
    pytest.importorskip("matplotlib")
    plot_trace(mission, tmp_path / "by_path.png")
    plot_trace(read_trace(mission), tmp_path / "by_trace.png")
    assert (tmp_path / "by_path.png").read_bytes() == (tmp_path / "by_trace.png").read_bytes()
    for wrong in (None, 3):
        with pytest.raises(ArgumentTypeError, match=r"give a Trace .* or the path of a trace"):
            plot_trace(wrong, tmp_path / "x.png")  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"nowhere\.jsonl"):
        plot_trace(tmp_path / "nowhere.jsonl", tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()

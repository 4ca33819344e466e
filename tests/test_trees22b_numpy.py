"""Session 22 (R2): NumPy numbers where the render API takes a number (docs/api.md).

``render_tree(..., tick=numpy.int64(3))`` was refused as no whole number, where
``Trace.frame_at(numpy.int64(3))`` takes it; ``plot_trace``'s ``start_s`` and ``end_s``
refused ``numpy.int64`` and ``numpy.float32`` (and took ``numpy.float64``, a float).
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import ArgumentTypeError
from pirate_bt.render.plot import plot_trace

numpy = pytest.importorskip("numpy")


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("numpy") / "run.jsonl"
    pirate_bt.simulate_tree("straight", params={"distance": "0.1 m"}, trace=path)
    return path


def test_a_numpy_tick_colours_the_diagram_as_its_int_does(trace: Path, tmp_path: Path) -> None:
    drawn = {}
    for tick in (3, numpy.int64(3), numpy.uint8(3)):
        out = tmp_path / f"{type(tick).__name__}.dot"
        pirate_bt.render_tree("straight", out, trace=trace, tick=tick, params={"distance": "0.1 m"})
        drawn[type(tick).__name__] = out.read_text(encoding="utf-8")
    assert 'label="straight: tick 3 at ' in drawn["int"]
    assert drawn["int64"] == drawn["int"] == drawn["uint8"]


@pytest.mark.parametrize("tick", [numpy.float64(3.0), numpy.bool_(True), True, 3.0])
def test_a_tick_that_is_no_whole_number_is_still_refused(
    trace: Path, tmp_path: Path, tick: object
) -> None:
    with pytest.raises(ArgumentTypeError, match="tick: give a tick's number"):
        pirate_bt.render_tree("straight", tmp_path / "t.dot", trace=trace, tick=tick)  # type: ignore[arg-type]


def test_a_plot_window_of_numpy_numbers_is_drawn(trace: Path, tmp_path: Path) -> None:
    out = tmp_path / "w.png"
    plot_trace(trace, out, start_s=numpy.int64(0), end_s=numpy.float32(0.5))  # type: ignore[arg-type]
    assert out.stat().st_size > 0

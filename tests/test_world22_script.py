"""The reference manoeuvre (``ScriptedDrive``) up and down a riser whose pipe steps out
to a wider diameter: a half passing the step is off the wall until its joints swing out,
so the half that holds must not be the one crossing it (docs/simulator.md).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.sim import Simulator
from pirate_bt.sim.script import ModelSink, ScriptedDrive

STEPPED = """name: stepped
diameter: 63 mm
segments:
  - {{id: level, type: straight, length: 1 m}}
  - {{id: foot, type: bend, direction: {way}}}
  - {{id: narrow, type: straight, length: 0.9 m}}
  - {{id: wide, type: straight, length: 0.9 m, diameter: 80 mm}}
"""


@pytest.mark.parametrize("way", ["up", "down"])
def test_the_script_crosses_a_step_in_a_riser_without_sliding(tmp_path: Path, way: str) -> None:
    # was (up): 384 slides, 0.77 m slid, and run_path returned 1.1 m short of the end
    network = tmp_path / "stepped.yaml"
    network.write_text(STEPPED.format(way=way), encoding="utf-8")
    sim = Simulator(network)
    drive = ScriptedDrive(sim, ModelSink(sim))
    seen: list[str] = []
    drive.run_path(progress=seen.append)
    counters = sim.counters()
    assert counters.violation_count == 0, dict(counters.violations)
    assert counters.slide_m == 0.0
    assert sim.model.s_m == pytest.approx(sim.model.path.length_m - 0.1, abs=0.01)
    assert seen == ["foot", "wide"]
    assert "over the step at 2.04 m" in "\n".join(drive.log)

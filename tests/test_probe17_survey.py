"""Probe 17: a survey at a tee whose way straight on is capped just past it.

A network of a straight, then a tee with a branch as its last segment: the tee's
way straight on ends at the tee (an end cap). The survey went straight through
first, the released front half was blocked at once past the opening (``front
across``), and the survey stopped with the main line written as *not surveyed to
its end*: a second insertion could never make the file whole (that line is not
extended), and surveying again stopped at the same cap.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt


def _capped(tmp_path: Path, diameter_mm: int) -> Path:
    path = tmp_path / f"capped-{diameter_mm}.yaml"
    path.write_text(
        f"""schema_version: 1
name: capped-tee
diameter: {diameter_mm} mm
segments:
  - {{id: before, type: straight, length: 2 m}}
  - id: tee
    type: tee
    branch:
      direction: left
      segments:
        - {{id: branch, type: straight, length: 1 m}}
""",
        encoding="utf-8",
    )
    return path


def _lines(network: pirate_bt.Network) -> list[object]:
    out: list[object] = []
    for seg in network.spec.segments:
        if seg.type == "tee":
            out.append(("tee", seg.branch.direction, [s.type for s in seg.branch.segments]))
        else:
            out.append(seg.type)
    return out


def test_a_capped_run_at_a_tee_ends_the_line_and_a_second_insertion_surveys_the_branch(
    tmp_path: Path,
) -> None:
    sim = _capped(tmp_path, 63)
    out = tmp_path / "surveyed.yaml"
    first = pirate_bt.survey(sim=sim, output=out)
    assert not first.succeeded and first.exit_code == 1
    assert "the way straight on through tee-1 is blocked just past it" in first.why
    assert first.navigation.counters.violations == 0
    # the main line is surveyed to where it ends, at the tee; only the branch is left
    assert len(first.unexplored) == 1
    assert first.unexplored[0].startswith("tee-1's branch (left, 63 mm): not entered")
    assert "not surveyed to its end" not in pirate_bt.load_network(out).spec.description
    assert "the main line after tee-1, blocked just past it, no turn tried" in first.why

    second = pirate_bt.survey(sim=sim, extend=out, output=out)
    assert second.succeeded, second.why
    assert second.unexplored == []
    assert "the main line after tee-1, blocked just past it, no turn tried" in second.why
    surveyed = pirate_bt.load_network(out)
    assert _lines(surveyed) == ["straight", ("tee", "left", ["straight"])]
    branch = surveyed.spec.segments[1].branch.segments[0]
    assert abs(branch.length - 1.0) <= 0.05


@pytest.mark.xfail(
    strict=True,
    reason="not yet: the straight-through attempt at a capped tee stops the navigation"
    " (a failed step ends it); going on into the branch in the same insertion needs the"
    " T-joint PAB to end cleanly there, which changes the golden runs' coverage records",
)
def test_one_insertion_surveys_a_capped_tee_whole(tmp_path: Path) -> None:
    result = pirate_bt.survey(sim=_capped(tmp_path, 63), output=tmp_path / "s.yaml")
    assert result.succeeded, result.why


@pytest.mark.xfail(
    strict=True,
    reason="not yet: in a tee of 51 to 59 mm capped just past it, the front tip meets the"
    " cap before any joint reaches the opening, so nothing the robot senses shows the tee",
)
def test_a_small_capped_tee_is_found(tmp_path: Path) -> None:
    result = pirate_bt.survey(sim=_capped(tmp_path, 51), output=tmp_path / "s.yaml")
    assert result.network is not None
    assert any(seg.type == "tee" for seg in result.network.spec.segments), result.why

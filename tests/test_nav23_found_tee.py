"""Session 23: a navigator with a map, in a pipe with a tee the map does not have on a
straight it drives along, went no further: each step stopped over the unmapped opening
(a map disagreement), the goal navigator asked again, and after three failed steps in a
row it was stopped, where a mission on the same map and truth re-plans through the tee
(its one clear meaning: the line goes on) and succeeds. A step now re-plans as a mission
does, the map corrected, and says so in the result's notes."""

from __future__ import annotations

from pathlib import Path

import pirate_bt
from pirate_bt.task.navigators import load_navigator

MAP = """\
schema_version: 1
name: m23
diameter: 63 mm
segments:
  - {id: before, type: straight, length: 4 m}
  - id: tee
    type: tee
    branch:
      direction: left
      segments:
        - {id: branch, type: straight, length: 1 m}
  - {id: after, type: straight, length: 1.5 m}
"""

# the same with a tee nobody drew 1.5 m in (pirate-bt network add-tee m23.yaml before 1.5m
# --direction right)
TRUTH = MAP.replace(
    "  - {id: before, type: straight, length: 4 m}\n",
    "  - {id: before, type: straight, length: 1.5 m}\n"
    "  - {id: extra, type: tee, length: 189 mm, branch: {direction: right, segments: []}}\n"
    "  - {id: before-rest, type: straight, length: 2.5 m}\n",
).replace("name: m23", "name: m23-as-built")


def test_a_navigator_goes_on_through_a_tee_its_map_lacks(tmp_path: Path) -> None:
    (tmp_path / "m23.yaml").write_text(MAP)
    (tmp_path / "truth.yaml").write_text(TRUTH)
    result = pirate_bt.navigate(
        load_navigator("goal", {"segment": "after"}),
        sim=tmp_path / "truth.yaml",
        map=tmp_path / "m23.yaml",
    )
    # was: failure, 'an opening was felt at 1.27 m ... where the map has no T-joint ...;
    # navigator 'goal' went on, and steps 1 to 3 failed in a row ...; it is stopped'
    assert result.status == "success", result.why
    assert result.counters.violations == 0
    assert result.truth_m is not None and result.truth_m > 4.19 + 0.5  # wholly in 'after'
    (note,) = result.notes
    assert note.startswith("step 1 (Step('t-joint', direction='straight')): a T-joint the map")
    assert "the map was corrected ('found-tee-1')" in note
    # what the navigator was told: the tee it passed, by the corrected map's name
    felt = [f for d in result.decisions for f in d.observation.felt]
    assert [(f.kind, f.segment) for f in felt][:1] == [("tee", "found-tee-1")]


def test_an_opening_near_the_map_s_own_tee_is_no_tee_it_lacks(tmp_path: Path) -> None:
    """No clear meaning where the opening may be the map's own tee met early (within the
    localiser's reach of it): the step's stop stands, as a mission's does, and the
    disagreement is the first cause (the bundled t-joint, a tee built 0.8 m before it)."""
    truth = tmp_path / "truth.yaml"
    truth.write_text(
        "schema_version: 1\nname: t-joint-as-built\ndiameter: 63 mm\nsegments:\n"
        "  - {id: before, type: straight, length: 1.2 m}\n"
        "  - {id: extra, type: tee, length: 189 mm, branch: {direction: right, segments: []}}\n"
        "  - {id: before-rest, type: straight, length: 0.8 m}\n"
        "  - {id: tee, type: tee, branch: {direction: left, segments: [{id: branch, type:"
        " straight, length: 2 m}]}}\n"
        "  - {id: after, type: straight, length: 2 m}\n"
    )
    result = pirate_bt.navigate(
        load_navigator("goal", {"segment": "after"}), sim=truth, map="t-joint"
    )
    assert result.status == "failure"
    assert result.why.startswith("belief and map disagree: an opening was felt at ")
    assert result.notes == []
    assert result.safe_state

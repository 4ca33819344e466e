"""Survey fixes from a probe of the survey mode: what a user sees (exit code, why, the
file written), each on a small network."""

from __future__ import annotations

from pathlib import Path

import pirate_bt
from pirate_bt import Step
from pirate_bt.errors import LinkError


class _Straight:
    def next_step(self, obs: pirate_bt.Observation) -> Step | None:
        return Step("straight", distance="1 m") if obs.step < 3 else None


# -- F6: a lost link in a navigation with no map is a link error (exit 3)


def test_a_lost_link_without_a_map_is_a_link_error() -> None:
    result = pirate_bt.navigate(_Straight(), sim="straight", faults="link_loss@5s")
    assert not result.succeeded and result.safe_state
    assert isinstance(result.error, LinkError), result.why
    assert result.exit_code == 3 and "link" in result.why


def test_a_survey_that_loses_the_link_exits_3(tmp_path: Path) -> None:
    out = tmp_path / "s.yaml"
    result = pirate_bt.survey(sim="straight", output=out, faults="link_loss@5s")
    assert not result.succeeded and result.exit_code == 3, result.why
    assert isinstance(result.navigation.error, LinkError)

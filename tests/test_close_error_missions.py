"""A mission, a navigation and a survey whose close could not stop the robot fail, exit 3.

The twin of ``test_link_leftovers13.py``'s tree runs: when neither the closing stop
nor the e-stop the close sends after it is acknowledged, the robot may be left moving
until its bridge's watchdog stops it. Every result that opened its own connection then
says so as its first cause (after the run's own, when the run had failed) and exits 3,
through the API and the command line.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt import Observation, Step
from pirate_bt.api.connection import Connection
from pirate_bt.cli import main
from pirate_bt.errors import LinkError

ROOT = Path(__file__).resolve().parents[1]
ROUTE = ROOT / "scenarios" / "straight.route"
# the bridge's STATEs still come (only the host's frames are lost) and, by the end of the
# close, report its watchdog tripped (before tests/test_fix20_link.py's fix: "the robot may
# still be moving until its bridge's watchdog stops it")
STOPPED = "the bridge reports its watchdog tripped, so its drives are stopped"


@pytest.fixture
def deaf_close(monkeypatch: pytest.MonkeyPatch) -> None:
    """From the close on, the host's frames are lost on the way to the bridge."""
    close = Connection.close

    def deaf(self: Connection) -> None:
        self.supervisor._port.session.link.write = lambda data: None  # type: ignore[attr-defined]
        close(self)

    monkeypatch.setattr(Connection, "close", deaf)


class _Once:
    """One short straight step, then done."""

    def next_step(self, obs: Observation) -> Step | None:
        return Step("straight", distance="0.2 m") if obs.step == 0 else None


def test_a_mission_that_succeeded_but_could_not_stop_the_robot_fails_with_exit_3(
    deaf_close: None, tmp_path: Path
) -> None:
    result = pirate_bt.simulate_mission(ROUTE, output=tmp_path / "out")
    assert result.run.succeeded  # every PAB did
    assert not result.succeeded and result.status == "failure"
    assert isinstance(result.close_error, LinkError)
    assert (
        result.why.startswith("the closing stop was never acknowledged") and STOPPED in result.why
    )
    assert result.exit_code == 3
    # the report, written after the close, says the same
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "the closing stop was never acknowledged" in report


def test_a_mission_that_failed_keeps_its_first_cause_then_the_close(deaf_close: None) -> None:
    result = pirate_bt.simulate_mission(ROUTE, max_time="3 s")
    assert not result.run.succeeded
    first, _, then = result.why.partition("; then ")
    assert "the closing stop" not in first and then.startswith("the closing stop was never")
    assert result.exit_code == 3


def test_the_mission_command_exits_3_naming_the_closing_stop(
    deaf_close: None, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["mission", str(ROUTE), "--sim", "straight", "--quiet"]) == 3
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "FAILED - the closing stop was never acknowledged" in last and STOPPED in last


def test_a_navigation_whose_close_could_not_stop_the_robot_fails_with_exit_3(
    deaf_close: None,
) -> None:
    result = pirate_bt.navigate(_Once(), sim="straight")
    assert result.steps == 1 and not result.succeeded and result.status == "failure"
    assert isinstance(result.close_error, LinkError)
    assert result.why.startswith("the closing stop was never acknowledged")
    assert result.exit_code == 3 and "FAILURE - the closing stop" in result.summary()


def test_a_survey_whose_close_could_not_stop_the_robot_fails_with_exit_3(
    deaf_close: None,
) -> None:
    result = pirate_bt.survey(sim="straight")
    assert not result.succeeded and result.status == "failure"
    assert "the closing stop was never acknowledged" in result.why
    assert result.exit_code == 3


def test_a_close_that_stopped_the_robot_changes_nothing() -> None:
    mission = pirate_bt.simulate_mission(ROUTE)
    navigation = pirate_bt.navigate(_Once(), sim="straight")
    assert mission.succeeded and mission.close_error is None and mission.exit_code == 0
    assert navigation.succeeded and navigation.close_error is None and navigation.exit_code == 0

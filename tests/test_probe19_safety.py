"""The protective layer in its modes, probed from docs/safety.md as a planner would.

Each test pins a bug a user saw, fixed here.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from typing import Any

import pytest

import pirate_bt
from pirate_bt.api import Connection
from pirate_bt.errors import InputError
from pirate_bt.robot import Half
from pirate_bt.safety import Drive, Outcome, Reason, operator
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.safety.operator import Confirmation, Mode
from pirate_bt.safety.tally import VerdictTally


@pytest.fixture
def sim_robot() -> Iterator[Connection]:
    with pirate_bt.connect("sim:straight") as connection:
        connection.supervisor.tick()
        yield connection


def _ticks(connection: Connection, n: int) -> None:
    sup = connection.supervisor
    for _ in range(n):
        sup.clock.sleep(0.1)
        sup.tick()


# -- a clamp of the front half while the front module is on its way back ----------------------


def test_a_front_clamp_waits_for_a_tilt_back_on_its_way(sim_robot: Connection) -> None:
    """With the front module tilted clear (61.7°), a `Tilt(0)` (rate-limited to a step
    to 52.7°) and then `Clamp(front, 0.7)` *passed*: the check read the tilt where the
    module still was, not where its setpoint was taking it, and the module swung into
    the front wheels' way as they pressed the wall (the simulator counted
    `front_pressed` damage). The clamp is now refused until the module is clear all the
    way to its setpoint, and passes once it is sent clear again."""
    sup = sim_robot.supervisor
    for _ in range(8):
        assert sup.move_front_clear().ok
        _ticks(sim_robot, 1)
    assert sup.tilt(0.0).ok  # back toward the middle: a step of 9°
    verdict = sup.clamp(Half.FRONT, 0.7)
    assert verdict.outcome is Outcome.REFUSE and verdict.reason is Reason.FRONT_NOT_CLEAR
    assert "on its way to 52.7°" in verdict.detail, verdict.detail
    _ticks(sim_robot, 10)
    assert sup.simulator is not None
    assert not sup.simulator.counters().damage, sup.simulator.counters()
    assert sup.move_front_clear().ok  # sent clear again, and there: the clamp passes
    _ticks(sim_robot, 5)
    assert sup.clamp(Half.FRONT, 0.7).ok
    _ticks(sim_robot, 10)
    assert not sup.simulator.counters().damage, sup.simulator.counters()


# -- a change of mode that is no hand-back ------------------------------------------------------


@pytest.mark.parametrize(
    ("start", "to"), [("autonomous", "supervised"), ("supervised", "autonomous")]
)
def test_a_change_between_autonomous_and_supervised_does_not_resume(start: str, to: str) -> None:
    """An operator's stop (`SafeStop`) followed by `SetMode` between autonomous and
    supervised left the safe state, as a `Resume` does: the step granted before the stop
    drove on (`drive(20 mm/s)` passed) with no one having resumed, and the stop's cause
    was gone. Only a hand-back from manual (the operator giving back the robot he held)
    leaves it now; a `Resume` still does."""
    sup = open_supervisor(network="straight", mode=start)
    try:
        sup.tick()
        if sup.request_confirmation("drive") is not Confirmation.GRANTED:
            sup.confirm("drive")
        assert sup.check(Drive(0.02)).ok
        sup.apply(operator.SafeStop("operator stop"))
        sup.apply(operator.SetMode(to))
        assert sup.mode is Mode(to)
        assert sup.safe_state_reason == "operator stop"
        verdict = sup.drive(0.02)
        assert verdict.reason is Reason.SAFE_STATE, verdict
        # taking over and handing back is the operator's resume, as before
        sup.apply(operator.SetMode("manual"))
        sup.apply(operator.SetMode(to))
        assert not sup.in_safe_state and sup.check(Drive(0.02)).ok
        sup.apply(operator.SafeStop("again"))
        sup.apply(operator.Resume())
        assert not sup.in_safe_state
    finally:
        sup.close()


# -- a scripted operator's times and ticks ------------------------------------------------------


@pytest.mark.parametrize(
    ("script", "said"),
    [
        ({"at_time": [("0.2 s", operator.EStop())]}, None),
        ({"at_time": [(None, operator.EStop())]}, "at_time: expected a time quantity"),
        (
            {"at_time": [(math.nan, operator.EStop()), (0.2, operator.SetMode("manual"))]},
            "at_time: nan is not a finite number",
        ),
        (
            {"at_tick": [(math.nan, operator.EStop()), (2, operator.SetMode("manual"))]},
            "at_tick: nan is not a tick number (a whole number)",
        ),
        ({"at_tick": [("2", operator.EStop())]}, "at_tick: '2' is not a tick number"),
        ({"at_tick": [operator.EStop()]}, "at_tick: not a (when, action) pair: EStop("),
    ],
)
def test_a_scripted_operator_checks_its_schedule(script: dict[str, Any], said: str | None) -> None:
    """`ScriptedOperator(at_time=[("0.2 s", EStop())])` (a time as text, as a run's
    `max_time` takes it) or a time of `None` raised `TypeError: '<=' not supported ...`
    out of every `supervisor.tick()`, ending a run on an internal error; a NaN time or
    tick sorted ahead held back every action after it, so a takeover scripted for 0.2 s
    never came, without a word. A time as text is now read as a time; anything that is
    no finite time, no whole tick or no pair is one line at construction."""
    if said is not None:
        with pytest.raises(InputError) as caught:
            operator.ScriptedOperator(**script)
        assert str(caught.value).startswith(said), caught.value
        assert "\n" not in str(caught.value)
        return
    sup = open_supervisor(network="straight", inputs=[operator.ScriptedOperator(**script)])
    try:
        for _ in range(3):
            sup.clock.sleep(0.1)
            sup.tick()
        assert sup.mode is Mode.ESTOP
    finally:
        sup.close()


# -- a verdict listener that raises ---------------------------------------------------------------


def test_a_listener_that_raises_is_no_refusal_and_stops_no_stop(
    sim_robot: Connection, caplog: pytest.LogCaptureFixture
) -> None:
    """A listener added with `sup.add_listener(fn)` that raised (a planner's bug, a file
    it writes to closed) raised out of `command()` after the command had gone out: the
    caller saw an exception for a drive at 20 mm/s that was under way. It raised out of
    `safe_state()` and `estop()` too, which never raise (in a tick, the protective
    hold's clamps after the safe state were not sent). The error is now logged once,
    one line, and the verdict stands."""
    sup = sim_robot.supervisor
    calls: list[str] = []

    def broken(verdict: Any) -> None:
        calls.append(str(verdict.command))
        raise RuntimeError("the file is closed\nsecond line")

    sup.add_listener(broken)
    with caplog.at_level(logging.DEBUG, logger="pirate_bt.safety"):
        assert sup.drive(0.02).outcome is Outcome.PASS
        sup.safe_state("operator stop")
        sup.estop("button")
    assert sup.in_safe_state and sup.mode is Mode.ESTOP
    assert len(calls) == 3  # called on, every verdict
    said = [
        r.getMessage()
        for r in caplog.records
        if r.levelno >= logging.ERROR and "listener" in r.getMessage()
    ]
    assert said == [
        "verdict listener test_a_listener_that_raises_is_no_refusal_and_stops_no_stop.<locals>"
        ".broken raised RuntimeError: the file is closed (the verdict stands; listeners are"
        " called on)"
    ], said


# -- a supervisor started latched -----------------------------------------------------------------


def test_a_supervisor_started_in_mode_estop_latches_the_bridge_with_a_reason() -> None:
    """`open_supervisor(mode="estop")` (a mode may be given as its text) set the mode
    alone: the bridge was not latched, and every refusal and the run's why said *e-stop
    latched (None)*. It is now an e-stop as `SetMode("estop")` is, sent to the bridge,
    with its reason."""
    sup = open_supervisor(network="straight", mode="estop")
    try:
        sup.tick()
        assert sup.port.health().estopped
        verdict = sup.drive(0.02)
        assert verdict.reason is Reason.ESTOP_LATCHED
        assert verdict.detail == "e-stop latched (the supervisor was started in mode estop)"
        assert sup.run_halted == "e-stop latched: the supervisor was started in mode estop"
        assert sup.reset_estop() and sup.mode is Mode.MANUAL
    finally:
        sup.close()


# -- the count of safe states ----------------------------------------------------------------------


def test_each_entry_into_the_safe_state_is_counted() -> None:
    """A stop, a resume and a new stop (and once more after a takeover) counted
    `safe_states` 1: a resume records no verdict, so the tally still took the robot for
    in its first safe state when the next one came. Each entry counts now; a stop
    repeated in the safe state still counts once."""
    sup = open_supervisor(network="straight")
    try:
        tally = VerdictTally(sup)
        sup.tick()
        sup.apply(operator.SafeStop("one"))
        sup.apply(operator.SafeStop("one again"))  # in it already: no new entry
        sup.apply(operator.Resume())
        sup.apply(operator.SafeStop("two"))
        sup.apply(operator.SetMode("manual"))
        sup.apply(operator.SetMode("autonomous"))  # the hand-back resumes
        sup.apply(operator.SafeStop("three"))
        assert tally.counters().safe_states == 3
        assert tally.first_safe_state is not None and tally.first_safe_state.reason == "one"
    finally:
        sup.close()


# -- open_supervisor's own arguments ---------------------------------------------------------


@pytest.mark.parametrize(
    ("options", "said"),
    [
        ({"mode": "bogus"}, "not a mode: 'bogus'"),
        ({"state_timeout_s": math.nan}, "state_timeout_s: nan is not a finite number"),
        ({"state_timeout_s": -1}, "state_timeout_s: -1 s is negative"),
    ],
)
def test_open_supervisor_checks_its_arguments_before_opening_the_port(
    options: dict[str, Any], said: str
) -> None:
    """`open_supervisor(url=..., mode="bogus")` opened the port, waited for the robot's
    first state and only then refused the mode (the Supervisor's), leaving the port
    open; on a port that cannot be opened the user was told about the port, not the
    mode. A NaN `state_timeout_s` waited for a first state for ever. Both are refused
    now before anything opens, one line."""
    with pytest.raises(InputError) as caught:
        open_supervisor(url="/dev/pirate-bt-no-such-port", **options)
    assert str(caught.value).startswith(said), caught.value
    assert "\n" not in str(caught.value)


# -- drive_reach of what is no speed ---------------------------------------------------------------


@pytest.mark.parametrize("name", ["text", "none", "nan", "bool", "huge", "too long to show"])
def test_drive_reach_of_no_speed_is_one_line(sim_robot: Connection, name: str) -> None:
    """`sup.drive_reach("80 mm/s")` (docs/safety.md: the speed a drive may ask for now)
    raised `TypeError: '>' not supported between instances of 'float' and 'str'` from
    inside the reckoning, and NaN came back as NaN. It is one `InputError` line now."""
    value = {
        "text": "80 mm/s",
        "none": None,
        "nan": math.nan,
        "bool": True,
        "huge": 10**400,
        "too long to show": 10**5000,
    }[name]
    with pytest.raises(InputError) as caught:
        sim_robot.supervisor.drive_reach(value)  # type: ignore[arg-type]
    text = str(caught.value)
    assert text.startswith("drive_reach: ") and text.endswith(
        "is no speed (a finite number of m/s)"
    )
    assert "\n" not in text and len(text) < 200
    assert sim_robot.supervisor.drive_reach(0.05) == pytest.approx(0.04)

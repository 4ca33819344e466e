"""The operator console: its text, the --keys script mode, and the full screen (headless)."""

from __future__ import annotations

import asyncio
import math
import subprocess
import sys
from collections.abc import Callable

import pytest

from pirate_bt.cli.console import ConsoleEngine, Snapshot, VerdictFeed, verdict_text
from pirate_bt.cli.console.view import degrees, millimetres_per_s, newton_metres
from pirate_bt.cli.teleop import TeleopSession
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half
from pirate_bt.robot.loader import load_robot
from pirate_bt.safety import Drive, Mode, Source, Verdict
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.safety.verdict import Outcome, Reason


def test_numbers_are_rounded_to_the_unit_shown() -> None:
    assert degrees(6.93889e-17) == "0.0°"
    assert degrees(-1e-12) == "0.0°"
    assert degrees(math.radians(12.34)) == "12.3°"
    assert millimetres_per_s(3.46945e-18) == "0 mm/s"
    assert millimetres_per_s(-0.0404) == "-40 mm/s"
    assert newton_metres(0.5249) == "0.52 N·m"
    assert degrees(None) == "--"
    assert degrees(math.nan) == "--°" or degrees(math.nan) == "--"


def _clip(value: float, sent: float, *, tick: int = 1) -> Verdict:
    motors = ("bend_1_drive", "bend_2_drive", "rotational_drive_a")
    return Verdict(
        outcome=Outcome.CLIP,
        command=Drive(value),
        source=Source.OPERATOR,
        sent=tuple(MotorCommand(m, ControlMode.VELOCITY, sent) for m in motors),
        reason=Reason.ACCELERATION_LIMIT,
        detail="; ".join(f"{m}: velocity change ... clipped to {sent}" for m in motors),
        stamp_s=tick * 0.05,
        tick=tick,
    )


def test_a_clipped_drive_is_one_line_whatever_the_number_of_motors() -> None:
    text = verdict_text(_clip(0.04, 0.02))
    assert text.count("\n") == 0
    assert "drive 40 mm/s" in text and "sent 20 mm/s" in text
    assert "bend_2_drive" not in text  # one value for all motors, not a line each
    assert "e-1" not in verdict_text(_clip(0.04, 3.46945e-18))


def test_the_feed_folds_a_ramp_into_one_line_with_a_count() -> None:
    feed = VerdictFeed()
    for tick, sent in enumerate((0.01, 0.02, 0.03), start=1):
        feed.add(_clip(0.04, sent, tick=tick))
    assert len(feed.lines) == 1
    assert "sent 30 mm/s" in feed.lines[0] and "(x3)" in feed.lines[0]
    feed.add(_clip(0.06, 0.04, tick=4))  # a different command starts a new line
    assert len(feed.lines) == 2


def _teleop(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "pirate_bt", "teleop", *args],
        capture_output=True,
        text=True,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )


def test_keys_mode_prints_one_rounded_line_per_command_and_caps_the_speed() -> None:
    done = _teleop("--sim", "straight", "--keys", "r" + "." * 25 + "w" * 8 + "?")
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "e-1" not in out and "e-0" not in out  # no 6.93889e-17
    assert all(line.count("drive") <= 1 for line in out.splitlines())
    assert "rear clamped" in out
    # Eight presses of 20 mm/s stop at the drive limit (100 mm/s), never above it.
    assert "drive 100 mm/s" in out and "drive 120" not in out and "160" not in out
    # The console prints each verdict itself; the log does not repeat it on stderr.
    assert "REFUSE" not in done.stderr and "CLIP" not in done.stderr


def test_the_console_refuses_to_start_without_a_terminal() -> None:
    done = _teleop("--sim", "straight")
    assert done.returncode == 2
    assert "terminal" in done.stderr and "--keys" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    # with a tree, --keys is refused: the line points at 'pirate-bt run' (it pointed
    # at --keys, which then said to use 'pirate-bt run': a circle)
    tree = _teleop("--sim", "straight", "--tree", "straight", "--param", "distance=0.2m")
    assert tree.returncode == 2
    assert "in scripts run the tree with 'pirate-bt run'" in tree.stderr, tree.stderr
    assert len(tree.stderr.strip().splitlines()) == 1


def _wait_for(
    app: object, pilot: object, test: Callable[[Snapshot], bool], what: str
) -> asyncio.Future[None]:
    async def wait() -> None:
        for _ in range(600):
            last = app.last  # type: ignore[attr-defined]
            if last is not None and test(last):
                return
            await pilot.pause(0.02)  # type: ignore[attr-defined]
        raise AssertionError(f"the console never showed {what}: {app.last}")  # type: ignore[attr-defined]

    return asyncio.ensure_future(wait())


async def _press(app: object, pilot: object, key: str) -> None:
    """``key`` to the console as ``pilot.press`` sends it, without the waits for an idle
    process that follow it there: the engine's thread keeps this process busy, so each
    ran out its 1 s limit (2 s a key, 10 of the full-screen test's 11 s). What a key
    does is waited for as an event, by :func:`_wait_for`."""
    from textual import events

    app.post_message(events.Key(key, key))  # type: ignore[attr-defined]
    await pilot.pause(0)  # type: ignore[attr-defined]


def _line(snapshot: Snapshot, label: str) -> str:
    return next(line.text for line in snapshot.status if line.label == label)


def test_full_screen_console_drives_and_e_stops_the_simulator() -> None:
    from pirate_bt.cli.console import OperatorConsole

    sup = open_supervisor(load_robot(), network="straight", seed=3, mode=Mode.MANUAL)
    engine = ConsoleEngine(TeleopSession(sup), period_s=0.05, wall_period_s=0.002)
    app = OperatorConsole(engine)

    async def scenario() -> None:
        async with app.run_test(size=(150, 45)) as pilot:
            await _wait_for(app, pilot, lambda s: True, "a first snapshot")
            await _press(app, pilot, "r")
            await _wait_for(
                app, pilot, lambda s: _line(s, "rear half").startswith("CLAMPED"), "rear clamped"
            )
            await _press(app, pilot, "a")  # rotate with one half clamped: passes
            await _press(app, pilot, "f")  # clamp front without moving it clear: refused
            await _wait_for(
                app,
                pilot,
                lambda s: any("REFUSE" in v and "front_not_clear" in v for v in s.verdicts),
                "the refused front clamp",
            )
            await _press(app, pilot, "e")
            await _wait_for(app, pilot, lambda s: "LATCHED" in _line(s, "e-stop"), "the e-stop")
            assert app.last is not None and _line(app.last, "mode") == "ESTOP"
            # The screen shows what the engine published: the status panel text.
            status = str(app.query_one("#status").render())
            assert "LATCHED" in status and "CLAMPED" in status
            await _press(app, pilot, "x")
            await _wait_for(app, pilot, lambda s: _line(s, "e-stop") == "clear", "the reset")
            await pilot.press("q")
            await pilot.pause(0.2)

    try:
        asyncio.run(scenario())
    finally:
        sup.close()
    assert sup.mode is Mode.MANUAL
    assert sup.half_states()[Half.REAR].value == "clamped"


def _supervised_runner(sup: object, params: dict[str, str]) -> Callable[[], object]:
    import dataclasses

    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.resources import find_file
    from pirate_bt.runner import Runner
    from pirate_bt.treefile import build, load_tree

    robot = sup.robot  # type: ignore[attr-defined]
    checked = load_tree(find_file("trees", "straight"), robot=robot, params=params)

    def factory() -> Runner:
        context = BuildContext(robot=robot, clock=sup.clock, supervisor=sup)  # type: ignore[attr-defined]
        tree = dataclasses.replace(checked, root=build(checked.spec, context))
        return Runner(
            tree,
            clock=sup.clock,  # type: ignore[attr-defined]
            period_s=0.05,
            safe_state=lambda: sup.safe_state("console test"),  # type: ignore[attr-defined]
            paused=lambda: bool(sup.tree_paused),  # type: ignore[attr-defined]
            setup_timeout_s=sys.float_info.max,
        )

    return factory


@pytest.mark.parametrize("answer", ["y", "n"])
def test_supervised_tree_waits_for_the_operator_in_the_console(answer: str) -> None:
    from pirate_bt.cli.console import OperatorConsole

    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.SUPERVISED)
    engine = ConsoleEngine(
        TeleopSession(sup),
        period_s=0.05,
        wall_period_s=0.002,
        runner_factory=_supervised_runner(sup, {"distance": "0.2 m"}),
    )
    app = OperatorConsole(engine)

    async def scenario() -> None:
        async with app.run_test(size=(150, 45)) as pilot:
            await _wait_for(app, pilot, lambda s: bool(s.pending), "a pending confirmation")
            assert app.last is not None
            first = app.last.pending[0]
            assert any("RUNNING" in line for line in app.last.tree)
            pending = str(app.query_one("#pending").render())
            assert first in pending
            await _press(app, pilot, answer)
            if answer == "y":
                await _wait_for(
                    app, pilot, lambda s: first not in s.pending, "the granted step move on"
                )
                # Keep granting until the tree finishes: each step as it waits.
                for _ in range(20):
                    await _wait_for(
                        app, pilot, lambda s: bool(s.pending) or bool(s.finished), "a step"
                    )
                    if app.last is not None and app.last.finished:
                        break
                    assert app.last is not None
                    step = app.last.pending[0]
                    await _press(app, pilot, "y")
                    await _wait_for(
                        app, pilot, lambda s, step=step: step not in s.pending, f"{step} granted"
                    )
                await _wait_for(app, pilot, lambda s: s.finished is not None, "the end")
            else:
                await _wait_for(app, pilot, lambda s: s.finished is not None, "the end")
            await pilot.press("q")
            await pilot.pause(0.2)

    try:
        asyncio.run(scenario())
    finally:
        sup.close()
    assert engine.result is not None
    if answer == "y":
        assert engine.result.succeeded, engine.finished
    else:
        assert not engine.result.succeeded
        assert sup.in_safe_state  # a denied step ends the run safe


def test_quitting_mid_tree_interrupts_it_and_leaves_the_robot_safe() -> None:
    from pirate_bt.cli.console import OperatorConsole

    sup = open_supervisor(load_robot(), network="straight", seed=2, mode=Mode.AUTONOMOUS)
    engine = ConsoleEngine(
        TeleopSession(sup),
        period_s=0.05,
        wall_period_s=0.002,
        runner_factory=_supervised_runner(sup, {"distance": "2 m"}),
    )
    app = OperatorConsole(engine)

    async def scenario() -> None:
        async with app.run_test(size=(150, 45)) as pilot:
            await _wait_for(
                app, pilot, lambda s: any("RUNNING" in line for line in s.tree), "a running tree"
            )
            await pilot.press("q")
            await pilot.pause(0.5)

    try:
        asyncio.run(scenario())
    finally:
        sup.close()
    assert engine.result is not None and engine.result.reason.value == "interrupted"
    assert engine.result.safe_state_called

"""Probe 18b of the operator console and teleop, as an operator at the keys.

A refused key changed the setpoints it stepped: two 'w' refused while the tree was in
charge set the kept speed to 40 mm/s, and the takeover that followed drove the robot
off at it (the console re-sends the kept speed every tick in manual).
"""

from __future__ import annotations

import asyncio
import io
import logging
import math
import os
import sys
from collections.abc import Callable

import pytest

from pirate_bt.cli.teleop import TeleopSession
from pirate_bt.robot import load_robot
from pirate_bt.safety import Mode
from pirate_bt.safety.factory import open_supervisor

pytestmark = pytest.mark.xdist_group("real-time")


def _steps(session: TeleopSession, n: int) -> None:
    for _ in range(n):
        session.sup.clock.sleep(0.05)
        session.step()


def _keys(session: TeleopSession, keys: str, ticks: int = 1) -> None:
    for key in keys:
        session.press(key)
        _steps(session, ticks)


def test_a_drive_refused_before_a_takeover_does_not_drive_after_it() -> None:
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.AUTONOMOUS)
    session = TeleopSession(sup)
    try:
        _keys(session, "ww")  # refused twice: the tree is in charge
        assert session.velocity_mps == 0.0  # was 0.04
        _keys(session, "mr", ticks=30)  # take over, clamp the rear half
        assert sup.simulator is not None
        assert sup.simulator.truth().velocity_mps == 0.0  # drove off at 40 mm/s
        _keys(session, "w", ticks=20)  # one press now is one step
        assert session.velocity_mps == 0.02
    finally:
        sup.close()


def test_refused_rotate_presses_do_not_add_up() -> None:
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.AUTONOMOUS)
    session = TeleopSession(sup)
    try:
        _keys(session, "ddd][")  # all refused: the tree is in charge
        assert session.rotation_rad == 0.0 and session.bend_rad == 0.0
        _keys(session, "mr", ticks=30)  # take over, clamp the rear half
        _keys(session, "d")
        assert math.isclose(session.rotation_rad, math.radians(5))  # was 20°
    finally:
        sup.close()


def test_keys_that_did_nothing_say_why_in_scripts() -> None:
    out = io.StringIO()
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.MANUAL)
    session = TeleopSession(sup, out)
    try:
        _keys(session, "emoy")
    finally:
        sup.close()
    text = out.getvalue()
    # was: nothing at all for m, o and y; the operator could not tell a key was lost
    assert "IGNORED take over: the e-stop is latched (x resets it)" in text, text
    assert "IGNORED hand back: the e-stop is latched" in text
    assert "IGNORED confirm: no step is waiting" in text


def test_a_reset_the_bridge_refuses_says_so_and_why() -> None:
    out = io.StringIO()
    sup = open_supervisor(
        load_robot(),
        network="straight",
        seed=1,
        mode=Mode.MANUAL,
        sim_faults=["board_fault:26@1s+2s"],
    )
    session = TeleopSession(sup, out)
    try:
        _keys(session, "e", ticks=30)  # t = 1.5 s: board 26 in fault
        _keys(session, "x")
        assert sup.mode is Mode.ESTOP
        assert "IGNORED e-stop reset: e-stop reset nacked NOT_READY" in out.getvalue()
        _steps(session, 50)  # recovered
        _keys(session, "x")
        assert sup.mode is Mode.MANUAL and sup.estop_reset_refusal is None
    finally:
        sup.close()


def test_the_console_shows_ignored_keys_and_the_protective_layers_errors() -> None:
    from textual import events

    from pirate_bt.cli.console import ConsoleEngine, OperatorConsole

    sup = open_supervisor(load_robot(), network="straight", seed=3, mode=Mode.MANUAL)
    engine = ConsoleEngine(TeleopSession(sup), period_s=0.05, wall_period_s=0.002)
    app = OperatorConsole(engine)

    async def scenario() -> None:
        async with app.run_test(size=(150, 45)) as pilot:
            # e, then m, as pilot.press posts them, without its waits for an idle process
            # (the engine's thread keeps it busy: each ran out its 1 s limit, 2 s a key)
            for key in ("e", "m"):
                app.post_message(events.Key(key, key))
            await pilot.pause(0)
            for _ in range(600):  # 12 s at least: the 4 s of those waits no longer come first
                if app.last is not None and any("IGNORED" in v for v in app.last.verdicts):
                    break
                await pilot.pause(0.02)
            logging.getLogger("pirate_bt.safety").error("could not send the stop of x: gone")
            await pilot.pause(0.1)
            panel = str(app.query_one("#verdicts").render())
            assert "IGNORED take over: the e-stop is latched" in panel, panel
            assert "error: could not send the stop of x: gone" in panel, panel
            await pilot.press("q")
            await pilot.pause(0.2)

    try:
        asyncio.run(scenario())
    finally:
        sup.close()


@pytest.mark.skipif(sys.platform == "win32", reason="a pty")
def test_sigterm_under_the_full_screen_ends_the_console_in_one_line() -> None:
    import pty
    import select
    import signal
    import time

    pid, fd = pty.fork()
    if pid == 0:  # the console, on a terminal of its own
        os.environ["TERM"] = "xterm-256color"
        os.execv(sys.executable, [sys.executable, "-m", "pirate_bt", "teleop", "--sim", "straight"])
    out = b""

    def read_until(done: Callable[[], bool], limit_s: float) -> None:
        nonlocal out
        end = time.monotonic() + limit_s
        closed = False
        while not done() and time.monotonic() < end:
            if closed:
                time.sleep(0.1)
            elif select.select([fd], [], [], 0.1)[0]:
                try:
                    out += os.read(fd, 65536)
                except OSError:  # the terminal closed: wait for the process alone
                    closed = True

    try:
        read_until(lambda: b"mm/s" in out, 60)  # the screen is up: a motion line
        assert b"mm/s" in out, out[-500:]
        read_until(lambda: False, 4)
        os.kill(pid, signal.SIGTERM)
        ended: list[int] = []

        def exited() -> bool:
            waited, status = os.waitpid(pid, os.WNOHANG)
            if waited:
                ended.append(os.waitstatus_to_exitcode(status))
            return bool(ended)

        read_until(exited, 30)
        # was: "terminated (SIGTERM)", then the engine thread, blocked on a screen
        # loop that was gone, kept the process alive for good
        assert ended == [143], out[-500:]
        assert b"pirate-bt: terminated (SIGTERM)" in out
        assert b"Traceback" not in out
    finally:
        if not ended:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        os.close(fd)


def test_ctrl_c_in_the_console_stops_a_running_tree_safe() -> None:
    import dataclasses
    import sys as _sys

    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.cli.console import ConsoleEngine, OperatorConsole
    from pirate_bt.resources import find_file
    from pirate_bt.runner import Runner
    from pirate_bt.treefile import build, load_tree

    sup = open_supervisor(load_robot(), network="straight", seed=2, mode=Mode.AUTONOMOUS)
    checked = load_tree(find_file("trees", "straight"), robot=sup.robot, params={"distance": "2 m"})

    def factory() -> Runner:
        context = BuildContext(robot=sup.robot, clock=sup.clock, supervisor=sup)
        tree = dataclasses.replace(checked, root=build(checked.spec, context))
        return Runner(
            tree,
            clock=sup.clock,
            period_s=0.05,
            safe_state=lambda: sup.safe_state("console test"),
            paused=lambda: bool(sup.tree_paused),
            setup_timeout_s=_sys.float_info.max,
        )

    engine = ConsoleEngine(
        TeleopSession(sup), period_s=0.05, wall_period_s=0.002, runner_factory=factory
    )
    app = OperatorConsole(engine)

    async def scenario() -> None:
        async with app.run_test(size=(150, 45)) as pilot:
            for _ in range(600):
                if app.last is not None and any("RUNNING" in line for line in app.last.tree):
                    break
                await pilot.pause(0.02)
            await pilot.press("ctrl+c")  # was: an unknown key, nothing happened
            for _ in range(300):
                if engine.result is not None:
                    break
                await pilot.pause(0.02)

    try:
        asyncio.run(scenario())
    finally:
        sup.close()
    assert engine.result is not None, "Ctrl-C did not stop the tree"
    assert engine.result.reason.value == "interrupted"
    assert engine.result.safe_state_called


def test_hand_back_returns_to_supervised_when_taken_over_from_it() -> None:
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.SUPERVISED)
    session = TeleopSession(sup)
    try:
        _keys(session, "m")
        assert sup.mode is Mode.MANUAL
        _keys(session, "o")
        assert sup.mode is Mode.SUPERVISED  # was autonomous: the tree's steps stopped asking
    finally:
        sup.close()
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.MANUAL)
    session = TeleopSession(sup)
    try:
        _keys(session, "o")
        assert sup.mode is Mode.AUTONOMOUS  # started in manual: as before
    finally:
        sup.close()


def test_keys_against_a_link_that_was_lost_exit_3(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import pirate_bt.api.connection as connection
    from pirate_bt.cli import main

    real = connection.connect

    def lossy(*args: object, **kwargs: object) -> object:
        return real(*args, faults="link_loss@1s", **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(connection, "connect", lossy)
    code = main(["teleop", "--sim", "straight", "--keys", "mr" + "." * 60])
    err = capsys.readouterr().err
    assert code == 3, err  # was 0: the script was told all went well
    assert "link lost" in err


def test_a_stop_the_supervisor_made_says_what_made_it() -> None:
    out = io.StringIO()
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.MANUAL)
    session = TeleopSession(sup, out)
    try:
        _keys(session, "pxe")
    finally:
        sup.close()
    text = out.getvalue()
    # was "PASS   stop [supervisor]" for both, saying nothing of why
    assert "stop [supervisor] safe_state: safe state: operator stop (teleop)" in text, text
    assert "stop [supervisor] estop_latched: e-stop: operator e-stop (teleop)" in text, text

"""Link-layer findings of a probe, each pinned by a test that failed before its fix.

1. A round trip longer than the retry budget made the unacknowledged release of the
   bridge's boot latch look like a latched e-stop (exit 1) instead of a link error.
2. A jittery link delivered a boot STATE (``NO_SESSION``) after the ``HELLO_REPLY``: the
   host counted a bridge reset, failed the boot latch release and the run stopped latched.
3. A bridge setting flag bit 4 in a 1.1 session was reported as ``estop_input``.
4. One CRC-valid ``STATE`` with a far-ahead seq hid every genuine one for ~300 s.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import pytest
from session_wire import CONFIG, LOG, ROBOT, Wire, messages, reply, state

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import LinkTimeout
from pirate_bt.link.codec import BridgeFlags, Hello
from pirate_bt.link.requests import Outcome, Request
from pirate_bt.link.robot_link import RobotLink

# -- 1. the boot latch release never acknowledged is a link error ----------------------------


def test_a_boot_latch_release_never_acknowledged_is_a_link_timeout() -> None:
    with pytest.raises(
        LinkTimeout, match="did not acknowledge the release of its boot latch"
    ) as exc:
        pirate_bt.simulate_tree(
            "straight", params={"distance": "1 m"}, network="straight", faults="delay=120ms"
        )
    assert exc.value.exit_code == 3
    assert "0.238 s" in str(exc.value)


def test_the_cli_exits_3_when_the_boot_latch_release_is_not_acknowledged(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(
        [
            "run",
            "trees/straight.yaml",
            "--param",
            "distance=1m",
            "--sim",
            "straight",
            "--faults",
            "delay=150ms",
        ]
    )
    assert code == 3
    err = capsys.readouterr().err
    assert "boot latch" in err
    assert "e-stop: the bridge reports its e-stop latched" not in err


# -- 2. a stale NO_SESSION frame after the HELLO_REPLY is not a bridge reset -----------------


def _stale_no_session_after_the_reply(boot_id: int) -> tuple[Wire, Request, Hello]:
    wire = Wire(hello=reply(flags=BridgeFlags.ESTOP, sessions=1))
    release = wire.session.estop_reset()
    wire.poll()
    # a boot STATE sent before the bridge took the HELLO, delivered after its reply
    wire.answer(state(3, flags=BridgeFlags.NO_SESSION | BridgeFlags.ESTOP))
    wire.poll(0.01)
    assert release.outcome is Outcome.FAILED
    hello = wire.sent()[-1]
    assert isinstance(hello, Hello)
    wire.answer(reply(seq=hello.seq, flags=BridgeFlags.ESTOP, sessions=2, boot_id=boot_id))
    wire.poll()
    return wire, release, hello


def test_a_stale_no_session_frame_is_not_counted_as_a_bridge_reset(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger=LOG)
    wire, _, _ = _stale_no_session_after_the_reply(boot_id=7)  # the same boot
    stats = wire.session.stats()
    assert (stats.bridge_resets, stats.sessions, stats.estopped) == (0, 2, True)
    assert (
        logging.WARNING,
        "a stale NO_SESSION frame (reordered link?) started a new session;"
        " the bridge was not reset (boot id 7 unchanged)",
    ) in messages(caplog)


def test_a_genuine_reset_under_the_boot_latch_release_is_still_counted() -> None:
    wire, _, _ = _stale_no_session_after_the_reply(boot_id=8)  # another boot
    assert wire.session.stats().bridge_resets == 1


def test_a_jittery_link_still_releases_the_boot_latch_and_runs() -> None:
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "1 m"}, network="straight", faults="jitter=150ms,seed=2"
    )
    assert (result.exit_code, result.why) == (0, "tree succeeded after 319 ticks")


# -- 3. no ESTOP_INPUT in a 1.1 session ------------------------------------------------------


@pytest.mark.parametrize(("minor", "reported"), [(1, False), (2, True)])
def test_the_estop_input_flag_is_read_in_a_1_2_session_only(minor: int, reported: bool) -> None:
    config = replace(CONFIG, protocol_minor=minor)
    wire = Wire(config=config, hello=reply(minor=minor))
    link = RobotLink(ROBOT, wire.session)
    wire.answer(state(1, flags=BridgeFlags.ESTOP | BridgeFlags.ESTOP_INPUT))
    wire.poll()
    assert wire.session.stats().estop_input is reported
    health = link.health()
    assert (health.estop_input, health.estopped) == (reported, True)


# -- 4. one far-ahead STATE does not hide every genuine one ----------------------------------


def test_a_far_ahead_state_is_given_up_after_ten_older_ones_in_a_row(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger=LOG)
    wire = Wire(hello=reply())
    wire.answer(state(100))
    wire.poll()
    wire.answer(state(100 + 30000))  # CRC-valid, far ahead: taken as newer
    wire.poll()
    for seq in range(101, 111):  # the genuine ones: not newer, dropped
        wire.answer(state(seq))
        wire.poll(0.01)
        assert wire.session.latest_state()[0].seq == 30100  # type: ignore[index]
    assert wire.session.stats().duplicates == 10
    wire.answer(state(111))  # the eleventh in a row: taken, the counter resynchronised
    wire.poll(0.01)
    assert wire.session.latest_state() == (state(111), wire.clock.now())
    assert wire.session.stats().duplicates == 10
    assert (
        logging.WARNING,
        "10 STATEs in a row not newer than seq 30100: resynchronised on seq 111",
    ) in messages(caplog)
    wire.answer(state(112), state(111))  # and the usual rules again
    wire.poll()
    assert wire.session.latest_state()[0].seq == 112  # type: ignore[index]
    assert wire.session.stats().duplicates == 11


def test_a_few_reordered_states_are_still_dropped() -> None:
    wire = Wire(hello=reply())
    wire.answer(state(50))
    wire.poll()
    for _ in range(3):
        for seq in range(41, 50):  # nine old ones, then a newer one: no resync
            wire.answer(state(seq))
        wire.answer(state(wire.session.latest_state()[0].seq + 1))  # type: ignore[index]
        wire.poll()
    assert wire.session.latest_state()[0].seq == 53  # type: ignore[index]
    assert wire.session.stats().duplicates == 27

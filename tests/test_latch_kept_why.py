"""A latch the bridge had when the link opened, and kept, says why: the release the
link asked for was refused (``NACK NOT_READY``, a board in ``FAULT``), or it was
latched in an earlier session. A run on it stopped with only *the bridge reports its
e-stop latched*, the refusal in a warning of the log."""

from __future__ import annotations

from pirate_bt.clock import SimClock
from pirate_bt.link import open_link
from pirate_bt.robot import load_robot
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.sim import Simulator

ROBOT = load_robot()


def test_a_boot_latch_whose_release_was_refused_names_the_refusal_and_the_board() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, faults=["board_fault:22@0s+1s"]) as sim:
        clock.advance(0.1)  # board 22 in FAULT before the host says HELLO
        supervisor = open_supervisor(ROBOT, url=sim.url, clock=clock)
        try:
            problem = supervisor.link_problem()
            health = supervisor.port.health()
        finally:
            supervisor.close()
    assert health.latch_kept == "the release of its boot latch was refused (NACK NOT_READY)"
    assert problem is not None
    assert problem.detail.startswith(
        "the bridge reports its e-stop latched: the release of its boot latch was refused"
        " (NACK NOT_READY); board 22 reports FAULT"
    ), problem.detail


def test_a_latch_from_an_earlier_session_says_so() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock) as sim:
        first = open_link(sim.url, ROBOT, clock)
        first.estop()
        clock.advance(0.1)
        first.poll()
        first.session.close()  # the line closed, the bridge still latched
        second = open_link(sim.url, ROBOT, clock)
        try:
            assert second.health().latch_kept == "latched in an earlier session (reset it)"
        finally:
            second.close()


def test_a_latch_released_at_the_handshake_leaves_nothing_to_say() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock) as sim:
        link = open_link(sim.url, ROBOT, clock)
        try:
            assert not link.health().estopped
            assert link.health().latch_kept == ""
        finally:
            link.close()


def test_a_kept_latch_released_later_is_forgotten_for_the_next_latch() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, faults=["board_fault:22@0s+0.5s"]) as sim:
        clock.advance(0.1)
        link = open_link(sim.url, ROBOT, clock)
        try:
            assert link.health().latch_kept
            clock.advance(0.6)  # the fault is over: the operator resets the e-stop
            link.poll()
            link.reset_estop()
            clock.advance(0.05)
            link.poll()
            assert not link.health().estopped
            assert link.health().latch_kept == ""
            link.estop()  # a new latch, of its own cause
            clock.advance(0.05)
            link.poll()
            assert link.health().estopped and link.health().latch_kept == ""
        finally:
            link.close()

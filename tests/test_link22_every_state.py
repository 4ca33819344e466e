"""Every STATE since the last tick (session 22, brief C item 1).

The host ticks at 20 Hz and the bridge sends a STATE every 10 ms: a tick read the
newest and never the four before it. A half riding a tee's opening in a riser held
nothing in one of those and held again by the next tick: the robot slid, and the
protective hold saw it one or two ticks late. The link now builds, when asked, the
snapshots of the STATEs between two it handed out (``RobotLink.states_between``), and
the protective hold judges each of them.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.link import open_link
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.factory import wait_for_state
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.safety.testing import FakePort
from pirate_bt.sim import Simulator

ROBOT = load_robot()
VTEE = Path(__file__).resolve().parent / "data" / "networks" / "vtee.yaml"


def test_the_link_hands_out_a_snapshot_of_every_state_between_two_ticks() -> None:
    clock = SimClock()
    sim = Simulator("straight", ROBOT, clock=clock)
    try:
        link = open_link(sim.url, ROBOT, clock)
        try:
            wait_for_state(link, clock, 5.0)
            first = link.state()
            assert first is not None
            clock.sleep(0.05)  # one 20 Hz tick: five 10 ms STATEs
            link.poll()
            newest = link.state()
            assert newest is not None and newest is not first
            between = link.states_between(first, newest)
            # the STATEs the tick did not read: every one taken since the first, but the
            # newest, oldest first (read in one poll here: they share its arrival)
            since = [at for _, at in link.session.states_taken() if at > first.stamp_s]
            assert len(since) >= 4, since
            assert len(between) == len(since) - 1
            stamps = [s.stamp_s for s in between]
            assert first.stamp_s < stamps[0] and stamps[-1] <= newest.stamp_s
            assert stamps == sorted(stamps)
            # each a whole snapshot, with readings as fresh as its own arrival
            assert set(between[0].readings) == set(newest.readings)
            assert all(max(r.stamp_s for r in s.readings.values()) == s.stamp_s for s in between)
            # nothing between a snapshot and itself, or backwards
            assert link.states_between(newest, newest) == ()
            assert link.states_between(newest, first) == ()
        finally:
            link.close()
    finally:
        sim.close()


class _PortWithStatesBetween(FakePort):
    """A fake port whose link took STATEs between two ticks (``between``, handed out once)."""

    def __init__(self, robot: RobotDescription, clock: SimClock) -> None:
        super().__init__(robot, clock)
        self.between: list[RobotState] = []

    def states_between(self, after: RobotState, newest: RobotState) -> tuple[RobotState, ...]:
        out, self.between = tuple(self.between), []
        return out


def test_a_state_between_two_ticks_in_which_no_half_holds_in_a_riser_is_held() -> None:
    clock = SimClock(10.0)
    port = _PortWithStatesBetween(ROBOT, clock)
    port.clamp_half(Half.REAR, 0.7)
    port.free_half(Half.FRONT, math.radians(40))  # steered into a tee, off the wall
    port.set_pitch(math.radians(90))
    sup = Supervisor(port, clock)
    sup.tick()
    assert not sup.in_safe_state  # the rear half holds
    # 10 ms later the rear's first joint swings off the wall over the opening: nothing
    # holds the robot in that STATE...
    clock.advance(0.01)
    wall = ROBOT.clamp.contact_angle(0.063)
    port.set(bend_3_angle=wall + math.radians(0.8), bend_3_spring=0.0)
    slipping = port.state()
    assert slipping is not None
    port.between.append(slipping)
    # ...and by the next tick it caught the edge again: the newest STATE shows it held
    clock.advance(0.04)
    port.clamp_half(Half.REAR, 0.7)
    sup.tick()
    # was: no safe state, no clamp (the tick read the newest STATE only)
    assert sup.in_safe_state
    why = sup.safe_state_reason
    assert why is not None
    assert why.startswith("steep_pipe_unclamped: no half holds the robot in a steep pipe"), why
    assert "rear bend_3 off the wall at" in why and "over an opening" in why
    front_joints = {ROBOT.joint_motor(m.name).name for m in ROBOT.bend_modules(Half.FRONT)}
    assert front_joints <= {c.motor for c in port.sent}  # the protective clamp went out


def test_a_port_without_states_between_is_judged_on_its_newest_state() -> None:
    clock = SimClock(10.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR, 0.7)
    port.set_pitch(math.radians(90))
    sup = Supervisor(port, clock)
    for _ in range(3):
        clock.advance(0.05)
        sup.tick()
    assert not sup.in_safe_state


def _riser_tee_built_off_the_drawing(tmp_path: Path) -> Path:
    """The riser tee drawn with its branch left and built at roll -80 deg, and a route
    that turns into it (as tests/test_fix20c_riser.py builds it): the rear half, the only
    one holding, is driven onto the opening and the robot slides on its edge."""
    (tmp_path / "vtee.yaml").write_text(VTEE.read_text(encoding="utf-8"), encoding="utf-8")
    built = yaml.safe_load(VTEE.read_text(encoding="utf-8"))
    branch = built["segments"][3]["branch"]
    del branch["direction"]
    branch["roll"] = "-80 deg"
    (tmp_path / "built.yaml").write_text(yaml.safe_dump(built, sort_keys=False), encoding="utf-8")
    route = tmp_path / "vtee.route"
    route.write_text(
        "network vtee.yaml\nat the bend turn up\nat the T-joint go left\n", encoding="utf-8"
    )
    return route


def test_a_slide_on_a_riser_tee_s_edge_is_stopped_sooner(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    route = _riser_tee_built_off_the_drawing(tmp_path)
    now = pirate_bt.simulate_mission(route, truth=tmp_path / "built.yaml")
    with monkeypatch.context() as patch:  # the hold on each tick's newest STATE only
        patch.delattr(RobotLink, "states_between")
        before = pirate_bt.simulate_mission(route, truth=tmp_path / "built.yaml")
    for result in (now, before):
        assert result.status == "failure"
        # the protective hold's words, after the mission's reading of them (fec1f76: a
        # branch on another side than drawn?)
        assert "steep_pipe_unclamped: no half holds the robot" in result.why, result.why
        assert "a branch on another side than drawn?" in result.why, result.why
        assert result.counters.damage == 0
    # the simulator's count of slides on the opening's edge: the run stops at the first
    # STATE no half holds in, one or two ticks before the tick that read one
    slid = now.counters.violation_kinds.get("sliding", 0)
    assert 0 < slid < before.counters.violation_kinds.get("sliding", 0)

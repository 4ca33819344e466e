"""The simulator's tees when the robot goes back and forth over an opening.

A tee is decided (straight or branch) when the front tip passes the middle of its
opening, and undecided again when the tip backs up before it; the model skips its
look at the tees while the tip stays in a stretch where none can change. These
drive :class:`PipeRobotModel` as ``test_sim_physics.py`` does (SI motor commands,
10 ms steps) and check what a user sees: the path choices, the TEE events, and
the segment the front module is in.
"""

from __future__ import annotations

import math

from test_sim_physics import STEER_RAD, Driver

from pirate_bt.robot.description import ControlMode, Half
from pirate_bt.sim import EventKind


def _opening(d: Driver) -> float:
    """The middle of the tee's opening, where the front tip decides it."""
    tee = next(p for p in d.model.path.pieces if p.segment == "tee")
    assert tee.opening_m is not None
    return tee.opening_m


def _tee_events(d: Driver) -> list[str]:
    return [e.detail for e in d.model.events if e.kind is EventKind.TEE]


def _steer_toward_branch(d: Driver) -> None:
    d.release(Half.FRONT)
    d.rotate(-math.pi / 2)
    d.joints(Half.FRONT, ControlMode.POSITION, STEER_RAD)
    d.run(1.0)


def test_backing_up_before_a_tee_decided_straight_undecides_it() -> None:
    d = Driver("t-joint")
    opening = _opening(d)
    d.clamp(Half.REAR)
    assert d.model.truth().path_choices == {}

    d.drive_to(opening + 0.1)  # past the opening, not steered: straight on
    truth = d.model.truth()
    assert truth.front_m > opening
    assert truth.path_choices == {"tee": "straight"}
    assert _tee_events(d) == ["tee:straight"]

    d.drive_to(opening - 0.1)  # backed up before the opening: undecided again
    truth = d.model.truth()
    assert truth.front_m < opening
    assert truth.path_choices == {}
    assert truth.module_segment["front"] == "before"
    assert _tee_events(d) == ["tee:straight"]

    d.drive_to(opening + 0.1)  # forward again: decided again, a second TEE event
    assert d.model.truth().path_choices == {"tee": "straight"}
    assert _tee_events(d) == ["tee:straight", "tee:straight"]

    d.drive_to(opening - 0.1)  # back once more, then steered toward the branch
    assert d.model.truth().path_choices == {}
    _steer_toward_branch(d)
    d.drive_to(opening + 0.2)  # the earlier "straight" no longer binds
    truth = d.model.truth()
    assert truth.path_choices == {"tee": "branch"}
    assert truth.module_segment["front"] == "branch"
    assert _tee_events(d) == ["tee:straight", "tee:straight", "tee:branch"]
    assert d.model.counters().stuck_events == 0


def test_backing_out_of_a_branch_undecides_the_tee() -> None:
    d = Driver("t-joint")
    opening = _opening(d)
    d.clamp(Half.REAR)
    straight_length = d.model.path.length_m
    _steer_toward_branch(d)
    d.drive_to(opening + 0.2)
    truth = d.model.truth()
    assert truth.path_choices == {"tee": "branch"}
    assert truth.module_segment["front"] == "branch"
    assert d.model.path.length_m != straight_length  # the path now runs up the branch

    d.drive_to(opening - 0.1)  # backed out of the branch, before the opening
    truth = d.model.truth()
    assert truth.path_choices == {}
    assert truth.module_segment["front"] == "before"
    assert d.model.path.length_m == straight_length

    d.release(Half.FRONT)  # straightened: forward again goes straight on
    d.drive_to(opening + 0.2)
    truth = d.model.truth()
    assert truth.path_choices == {"tee": "straight"}
    assert truth.module_segment["front"] == "after"
    assert _tee_events(d) == ["tee:branch", "tee:straight"]
    assert d.model.counters().stuck_events == 0

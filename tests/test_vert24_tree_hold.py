"""A tree run that fails in a riser hands the robot back on both halves (vert24).

A PAB stopped half-way up a riser (the top bend) leaves one half steered, free, the
other alone holding the robot. A mission and a navigation clamped that half after the
stop; a tree run (``simulate_tree``, ``run_tree``, ``pirate-bt run``) did not, however
it failed: the tree failing, a time limit, a refused command, an exception or Ctrl-C in
planner code. Now it does, the same way (``task.secure.hold_both``), and where nothing
may clamp (the link lost) the result says the robot may be unclamped in a riser.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.pipes import network_from_data
from pirate_bt.resources import data_dir
from pirate_bt.robot import Half
from pirate_bt.sim import model as sim_model

AT_S = 16.0
"""Clock time at which the bend PAB below has its rear half steered, free, the front
half alone holding the robot at the top of the riser (pitch 66°)."""

HELD = "the rear half, left free in a steep pipe (pitch 66°), was clamped: both halves hold"

RISER = {
    "name": "riser-top",
    "diameter": "63 mm",
    "segments": [
        {"id": "level", "type": "straight", "length": "0.6 m"},
        {"id": "foot", "type": "bend", "direction": "up"},
        {"id": "riser", "type": "straight", "length": "1.2 m"},
        {"id": "top", "type": "bend", "direction": "right"},
        {"id": "run", "type": "straight", "length": "1 m"},
    ],
    "start": {"position": "1.7 m"},  # in the riser, 0.2 m below its top bend
}


@pytest.fixture
def models(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every simulator model made, to read the truth at the end of a run."""
    made: list[Any] = []
    init = sim_model.PipeRobotModel.__init__

    def keep(self: Any, *args: Any, **kwargs: Any) -> None:
        init(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(sim_model.PipeRobotModel, "__init__", keep)
    return made


def _raise_at(exc: BaseException) -> Any:
    """An ``observe`` whose hook raises ``exc`` once the rear half is free."""

    def observe(runner: Any, connection: Any) -> None:
        def post(_info: Any) -> None:
            if connection.clock.now() >= AT_S:
                raise exc

        runner.add_post_tick(post)

    return observe


def _refused_tree() -> dict[str, Any]:
    hold = str(data_dir("trees") / "lib" / "hold.yaml")
    children = [
        {"type": "subtree", "name": "hold", "ref": hold},
        {"type": "unclamp", "name": "free rear", "half": "rear"},
        {"type": "unclamp", "name": "free front", "half": "front"},  # refused: steep
    ]
    return {"name": "refused", "root": {"type": "sequence", "name": "s", "children": children}}


def _held(model: Any) -> None:
    truth = model.truth()
    assert abs(truth.slope_rad) > 1.0  # still up in the riser
    assert truth.halves[Half.FRONT].clamped and truth.halves[Half.REAR].clamped
    assert truth.velocity_mps == 0 and not truth.sliding
    assert model.counters().violation_count == 0


@pytest.mark.parametrize(
    ("options", "why"),
    [
        ({"max_time": AT_S}, "time limit of 16 s reached"),
        ({"observe": _raise_at(RuntimeError("hook broke"))}, "RuntimeError: hook broke"),
        ({"observe": _raise_at(KeyboardInterrupt())}, "interrupted (Ctrl-C)"),
        ({"tree": "refused"}, "refused unclamp(front): steep_pipe_unclamped"),
    ],
    ids=["time-limit", "callback-raises", "ctrl-c", "refused"],
)
def test_a_tree_run_stopped_in_a_riser_leaves_both_halves_clamped(
    models: list[Any], options: dict[str, Any], why: str
) -> None:
    tree: Any = _refused_tree() if options.pop("tree", None) else "bend"
    result = pirate_bt.simulate_tree(
        tree,
        network=network_from_data(RISER),
        params={"roll": "90 deg"} if tree == "bend" else None,
        **({"max_time": "60 s"} | options),
    )
    assert result.status == "failure" and result.safe_state
    assert result.why.startswith(why)  # the first cause, still
    # was: the rear half left steered (or released) and free, the front alone holding
    _held(models[-1])
    assert result.after_stop is not None and "was clamped: both halves hold" in result.after_stop


def test_the_cli_says_what_was_done_after_the_stop(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], models: list[Any]
) -> None:
    import yaml

    network = tmp_path / "riser-top.yaml"
    network.write_text(yaml.safe_dump({"schema_version": 1, **RISER}), encoding="utf-8")
    # the top turns right, the tree is told left: it fails with the rear half steered
    code = main(["run", "bend", "--param", "roll=-90deg", "--sim", str(network), "-q"])
    assert code == 1
    err = capsys.readouterr().err.splitlines()
    assert err[-2] == f"pirate-bt: after the stop, {HELD.replace('66°', '90°')}"
    assert err[-1].startswith("pirate-bt: bend: FAILURE - blocked: every drive draws stall")
    _held(models[-1])


def test_a_link_lost_in_a_riser_says_the_robot_may_be_unclamped(models: list[Any]) -> None:
    result = pirate_bt.simulate_tree(
        "bend",
        network=network_from_data(RISER),
        params={"roll": "90 deg"},
        faults=f"link_loss@{AT_S}s",
        max_time="60 s",
    )
    assert result.why.startswith("link_silent: nothing heard from the bridge")
    assert result.exit_code == 3
    assert result.after_stop == (
        "the robot may be unclamped in a riser: only its front half held it in a steep pipe"
        " (pitch 66°) at the last reading; the rear half, left free, could not be clamped:"
        " the link is down (link_down: the link to the robot is not connected)"
    )
    truth = models[-1].truth()  # the bridge keeps the clamps: the front half holds
    assert truth.halves[Half.FRONT].clamped and not truth.halves[Half.REAR].clamped


def test_an_e_stop_in_a_riser_keeps_the_clamps_and_says_only_one_half_holds(
    models: list[Any],
) -> None:
    def observe(runner: Any, connection: Any) -> None:
        def post(_info: Any) -> None:
            if connection.clock.now() >= AT_S and not connection.supervisor.estopped:
                connection.supervisor.estop("operator pressed e-stop")

        runner.add_post_tick(post)

    result = pirate_bt.simulate_tree(
        "bend",
        network=network_from_data(RISER),
        params={"roll": "90 deg"},
        observe=observe,
        max_time="60 s",
    )
    assert result.status == "failure"
    assert result.after_stop is not None
    assert result.after_stop.startswith(
        "the robot may be unclamped in a riser: only its front half held it"
    )
    assert result.after_stop.endswith(
        "the robot is e-stopped (an e-stop keeps the clamps as they are)"
    )
    truth = models[-1].truth()  # nothing moved after the e-stop: the front half holds
    assert truth.halves[Half.FRONT].clamped and not truth.halves[Half.REAR].clamped

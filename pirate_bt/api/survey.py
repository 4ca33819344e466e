"""``survey(sim=...)``: map a network nobody has drawn, and write it as a network file.

A survey is the built-in ``explore`` navigator (:class:`~pirate_bt.ExploreNavigator`)
run by :func:`pirate_bt.navigate` with no map: depth-first through every branch,
backing out of the branches the robot fits. See docs/navigators.md (Built-in
navigators) for what it finds and how.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pirate_bt.api.navigation import navigate
from pirate_bt.api.process_run import one_run_in_process
from pirate_bt.atomic import new_folders_undone
from pirate_bt.task.explore import ExploreNavigator
from pirate_bt.task.navigate import NavigationResult
from pirate_bt.task.navigate_result import counted, steps_text

__all__ = ["SurveyResult", "survey"]


@dataclass
class SurveyResult:
    """How a survey went, and the network it found.

    Attributes:
        navigation: The navigation underneath (every decision, PAB and counter).
        network: The surveyed network (``None`` when nothing was surveyed); a
            :class:`~pirate_bt.pipes.Network` that plans and runs routes.
        output: Where it was written (``None``: not written).
        unexplored: What was not surveyed, each named with why: tee branches never
            entered (written as stubs) and, when the survey stopped, the line the robot
            was in (written up to the last feature surveyed in it).
    """

    navigation: NavigationResult
    network: Any = None
    output: Path | None = None
    unexplored: list[str] = field(default_factory=list)

    @property
    def succeeded(self) -> bool:
        """True when every line was surveyed to where it ends (a cap, or a bend at a roll
        the survey does not try: ``why`` names each end) and every step succeeded."""
        return self.navigation.succeeded

    @property
    def status(self) -> str:
        """``"success"`` or ``"failure"``, as every other result's (the navigation's)."""
        return self.navigation.status

    @property
    def why(self) -> str:
        """The first cause of the end (the failing step's, or what was not surveyed)."""
        return self.navigation.why

    @property
    def failing_node(self) -> str | None:
        """Path of the node where the step named first in :attr:`why` failed, if one did."""
        return self.navigation.failing_node

    @property
    def exit_code(self) -> int:
        """The command line's exit code: 0 whole, 1 stopped safe or incomplete, 3 link."""
        return self.navigation.exit_code

    @property
    def counters(self) -> Any:
        """The navigation's :class:`~pirate_bt.Counters`, as every other result's."""
        return self.navigation.counters

    @property
    def safe_state(self) -> bool:
        """The robot was left in its safe state (the navigation's)."""
        return self.navigation.safe_state

    @property
    def error(self) -> BaseException | None:
        """The exception that ended the survey, if one did (a lost link: ``LinkError``),
        as every other result's (the navigation's)."""
        return self.navigation.error

    @property
    def close_error(self) -> Any:
        """Set when closing the link after the survey could not make the robot safe (the
        navigation's :attr:`~pirate_bt.task.navigate_result.NavigationResult.close_error`)."""
        return self.navigation.close_error

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON values, as every other result's: the navigation's
        (:meth:`NavigationResult.as_dict <pirate_bt.NavigationResult.as_dict>`) with
        ``survey``: what was found (``counts``), the network found as its file's
        values (``network``, ``None`` when nothing was), ``output`` and
        ``unexplored``."""
        out = self.navigation.as_dict()
        network = None
        if self.network is not None:
            network = self.network.spec.model_dump(mode="json", exclude_none=True)
        out["survey"] = {
            "counts": self.counts(),
            "network": network,
            "output": None if self.output is None else str(self.output),
            "unexplored": list(self.unexplored),
        }
        return out

    def counts(self) -> dict[str, int]:
        """Straights, bends, tees and reducers found, over every line."""
        out = {"straight": 0, "bend": 0, "tee": 0, "reducer": 0}
        if self.network is None:
            return out

        def walk(segments: list[Any]) -> None:
            for seg in segments:
                out[seg.type] = out.get(seg.type, 0) + 1
                if seg.type == "tee":
                    walk(seg.branch.segments)

        walk(list(self.network.spec.segments))
        return out

    def summary(self) -> str:
        """One line for people."""
        n = self.counts()
        found = ", ".join(counted(n[k], k) for k in ("straight", "bend", "tee", "reducer"))
        if self.unexplored:
            found += f", {len(self.unexplored)} not surveyed"
        where = f" -> {self.output}" if self.output is not None and self.network else ""
        verb = "SUCCESS" if self.succeeded else "FAILURE"
        return (
            f"survey: {verb} - {self.why} ({found}{where};"
            f" {steps_text(self.navigation.steps)}, {self.navigation.sim_time_s:.1f} s clock,"
            f" {self.navigation.wall_s:.1f} s wall)"
        )


def _radius_fits(radius_m: float, robot: Any) -> None:
    """Refuse, before anything connects, a bend radius under half the narrowest pipe the
    robot fits: no bend it finds could be written (a bend's radius is at least half its
    diameter). A survey with ``radius="1 mm"`` drove the whole network and then wrote
    nothing, *navigator 'explore' raised NetworkGeometryError*."""
    from pirate_bt.api.options import load_robot_like
    from pirate_bt.errors import InputError

    narrowest_m = min(p.diameter for p in load_robot_like(robot).clamp.contact_angles)
    if radius_m < narrowest_m / 2 - 1e-9:
        raise InputError(
            f"explore: radius {radius_m * 1000:g} mm is less than half the narrowest pipe the"
            f" robot fits ({narrowest_m * 1000:g} mm), and a bend's radius is at least half"
            f" its pipe's diameter: give {narrowest_m * 500:g} mm or more"
        )


def _folders_to_make(output: Path | None) -> list[Path]:
    """The folders on the way to ``output`` that do not exist yet, innermost first."""
    if output is None:
        return []
    return [p for p in (output.parent, *output.parent.parents) if not p.exists()]


def _put_in_straight(sim: Any, robot: Any) -> None:
    """Refuse, before anything connects, a simulated pipe that puts the robot in across a
    bend or a T-joint, or longer than its main line, or further in than its length (a
    ``start`` position): the survey measures its first straight from the rear tip at the
    pipe's mouth, and wrote pipe that is not there (0.3 m of straight, then a bend up:
    *run-2, 275 mm at 23.9 deg*, exit 0)."""
    from pirate_bt.api.options import load_robot_like
    from pirate_bt.errors import InputError
    from pirate_bt.pipes import Network, PieceKind, load_network
    from pirate_bt.task.plan import robot_length_m

    try:  # a network that does not load is refused where the simulator loads it
        net = sim if isinstance(sim, Network) else load_network(sim or "straight")
        path = net.path({})
    except Exception:
        return
    length_m = robot_length_m(load_robot_like(robot))
    given = net.spec.start.position
    front_m = min(max(given if given is not None else length_m, length_m), path.length_m)
    turns = (PieceKind.BEND, PieceKind.TEE, PieceKind.TEE_TURN)
    under = [p for p in path.pieces if p.kind in turns and p.start_m < front_m - 1e-6]
    if front_m < length_m - 1e-6:
        why = f"has a main line of {path.length_m:.2f} m, shorter than the robot"
    elif front_m > length_m + 1e-6:
        why = f"puts its front tip at {front_m:.2f} m (start.position), not at the mouth"
    elif under:
        kind = "bend" if under[0].kind is PieceKind.BEND else "T-joint"
        why = f"puts it in across the {kind} {under[0].segment!r}: it must be on straight pipe"
    else:
        return
    raise InputError(
        f"sim: a survey measures its first straight from the pipe's mouth, the robot"
        f" ({length_m:.2f} m long) put in just inside it, and the simulated network"
        f" {net.spec.name!r} {why}"
    )


def _take_away(made: list[Path]) -> None:
    """Take away again the folders a survey made for a file it did not write (*nothing
    was surveyed: no file is written* left them, empty), while they are empty."""
    for path in made:
        try:
            path.rmdir()
        except OSError:  # one that holds anything stays, and so do those above it
            break


@one_run_in_process("survey")
def survey(
    *,
    sim: Any = None,
    port: str | Path | None = None,
    output: str | Path | None = None,
    seed: int = 0,
    faults: str | Iterable[str] | None = None,
    trace: str | Path | None = None,
    robot: Any = None,
    max_time: str | float = "3600 s",
    search: str | float = "3 m",
    radius: str | float = "90 mm",
    name: str = "surveyed",
    firmware: bool = False,
    extend: Any = None,
) -> SurveyResult:
    """Survey a network with no map and write what was found as a network file.

    Args:
        sim: The simulator's network, the pipe as it really is (a bundled name, a
            file or a ``Network``; default ``"straight"`` when no ``port``).
        port: A real robot (serial port or pyserial URL) instead of the simulator.
        output: Where to write the surveyed network (``.yaml``), whole or never
            (also when the survey stops early: what was surveyed so far).
        seed: The simulator's seed.
        faults: Simulator and link faults, as for :func:`pirate_bt.simulate_tree`.
        trace: A directory for the navigation's records and per-step traces.
        robot: The robot description (default: bundled).
        max_time: Clock time the survey may take (its time budget).
        search: How far one straight step drives before it looks again.
        radius: The bends' centre-line radius (assumed, not measured).
        name: The surveyed network's name.
        firmware: Simulator only: run it through the real firmwares in simavr.
        extend: A surveyed network (a file, a ``Network`` or its spec) with a tee
            branch left as a stub (a branch the robot could not back out of): this
            survey is a second insertion. It drives to the first stub, choosing at
            each tee by the survey, surveys that branch, and writes the surveyed
            network with it filled in (``output`` may be the same file). Stubs it
            leaves are in ``unexplored``, for a further insertion.

    Returns:
        SurveyResult: The navigation and the network found; a survey that stops is a
            result, not an exception (``why`` names the cause; the robot is safe).

    Raises:
        InputError: a bad option or network.
        LinkError: the robot cannot be reached.

    Example::

        import pirate_bt

        result = pirate_bt.survey(sim="t-joint", output="surveyed.yaml")
        print(result.summary())
        mission = pirate_bt.simulate_mission("my.route", network="surveyed.yaml",
                                             truth="t-joint")
        # a branch left as a stub: put the robot in again
        if result.unexplored:
            pirate_bt.survey(sim="t-joint", extend="surveyed.yaml", output="surveyed.yaml")
    """
    from pirate_bt.api.options import plain_number

    explore = ExploreNavigator(  # a NumPy length as the number it is
        output=output,
        search=plain_number(search),
        radius=plain_number(radius),
        name=name,
        extend=extend,
    )
    _radius_fits(explore.radius_m, robot)
    if port is None and extend is None:  # a second insertion follows the first's map
        _put_in_straight(sim, robot)
    # a survey refused before it runs (a fault's unknown target) leaves no empty folder
    # made for its output, as navigate leaves none for its trace
    undone = (
        new_folders_undone(explore.output.parent)
        if explore.output is not None
        else contextlib.nullcontext()
    )
    made = _folders_to_make(explore.output)
    with undone:
        if explore.output is not None:  # before anything connects, as navigate's trace
            from pirate_bt.api.options import output_path, writable_folder
            from pirate_bt.errors import InputError

            if explore.output.suffix.lower() not in (".yaml", ".yml"):
                # a network file: output="planner.py" was overwritten with the network's
                # YAML
                raise InputError(
                    f"output: {explore.output} is not a .yaml file name; the surveyed"
                    " network is written as YAML"
                )
            writable_folder(explore.output.parent, "output")
            # no pipe or device, and the pipe as it really is must survive its survey
            # (extend= may be the same file)
            output_path(explore.output, "output", {"simulated network": sim, "robot": robot})
        navigation = navigate(
            explore,
            sim=sim,
            port=port,
            seed=seed,
            faults=faults,
            trace=trace,
            robot=robot,
            max_time=max_time,
            max_steps=10_000,
            firmware=firmware,
        )
    if not navigation.succeeded and explore.network is None:
        # blocked going straight on through a tee just found: the line ends there
        # (or over a second opening close after it, no half holding)
        ended = explore.ended_at_tee(navigation.failing_node, navigation.why, navigation.off_wall)
        # blocked passing a bend just found: a second one (or the end) too close after it,
        # or a tee's opening there
        ended = ended or explore.ended_in_bend(
            navigation.failing_node, navigation.why, navigation.belief_m, navigation.off_wall
        )
        navigation.why = ended or navigation.why
        last = navigation.decisions[-1] if navigation.decisions else None
        explore.save(f"stopped: {navigation.why}", last)  # a failed step: keep what was surveyed
        if explore.invalid is not None and explore.invalid not in navigation.why:
            navigation.why += f"; {explore.invalid}"  # what was surveyed is not written
        elif explore.network is None and explore.output is not None:
            nothing = "nothing was surveyed: no file is written"
            if nothing not in navigation.why:
                navigation.why += f"; {nothing}"  # as a survey that ends on its own says
    if explore.ends and explore.ends_note() not in navigation.why:
        navigation.why += f"; {explore.ends_note()}"  # a written end may be a bend
    if explore.network is None:  # no file written: no folder made for it stays either
        _take_away(made)
    network = None
    if explore.network is not None:
        from pirate_bt.pipes import Network

        network = Network(explore.network, source=str(output) if output else name)
    return SurveyResult(
        navigation,
        network=network,
        output=explore.output if explore.network is not None else None,
        unexplored=list(explore.unexplored),
    )

"""``navigate(navigator)``: planner code in the loop, one supervised step at a time.

See docs/navigators.md for the loop, the observation, the steps and the guarantees,
and :mod:`pirate_bt.task.navigate` for how a step runs.
"""

from __future__ import annotations

import contextlib
import copy
import inspect
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from pirate_bt.api.connection import connect
from pirate_bt.api.observing import never_runs, uncallable_with
from pirate_bt.api.options import (
    NO_LIMIT,
    fault_list,
    fraction,
    load_robot_like,
    network_name,
    params_mapping,
    plain_number,
    port_url,
    positive_time_s,
    seed_value,
    split_faults,
    tick_period_s,
)
from pirate_bt.api.process_run import one_run_in_process
from pirate_bt.api.results import closing_why
from pirate_bt.atomic import new_folders_undone
from pirate_bt.behaviours.foreign import one_line
from pirate_bt.errors import ArgumentTypeError, InputError, shown
from pirate_bt.task.localise import MAP_FRACTION
from pirate_bt.task.navigate import NavigationResult, run_navigation
from pirate_bt.task.navigation import Navigator
from pirate_bt.task.navigators import (
    builtin_name,
    check_navigator_map,
    load_navigator,
    navigator_method,
)
from pirate_bt.task.secure import hold_both
from pirate_bt.task.start_check import check_map_start

__all__ = ["MAX_DEADLINE_S", "MAX_STEPS", "navigate"]

MAX_STEPS = 1_000_000
"""The most steps one navigation may be given."""

MAX_DEADLINE_S = 24 * 3600.0
"""The longest wall time one decision of a navigator may be given (a day)."""


def _trace_folder(trace: Any) -> Path:
    from pirate_bt.api.options import output_folder

    return output_folder(trace, "trace")


def _not_a_trace_file(trace: Any) -> Path:
    """``trace`` as a navigation takes it: a folder, not a name of a trace file. A tree's
    and a mission's ``trace=`` is a file, and ``trace="nav.jsonl"`` here made a folder
    named ``nav.jsonl``, ``navigation.jsonl`` and the step traces in it. A folder that is
    there already is taken whatever its name.

    Raises:
        InputError: a name that ends as a trace file does (``.jsonl``, ``.mcap``, ...),
            one line naming ``trace``; or a bad folder (:func:`output_folder`).
    """
    from pirate_bt.errors import ConfigurationError
    from pirate_bt.trace.formats import suffix_of
    from pirate_bt.trace.writer import WRITERS

    folder = _trace_folder(trace)
    if folder.is_dir():
        return folder
    try:
        suffix = suffix_of(folder, WRITERS)
    except (InputError, ConfigurationError):  # no trace file's name: a folder's
        return folder
    stem = str(folder)[: -len(suffix)] or "trace"
    raise InputError(
        f"trace: {folder} is the name of a trace file ({suffix}), but a navigation writes"
        " a folder: navigation.jsonl (every decision) and one trace per step"
        f" (step-001.jsonl, ...); give a folder, e.g. {stem!r}"
    )


def _make_trace_folder(folder: Path) -> None:
    from pirate_bt.api.options import writable_folder

    # made and written to before anything connects: /proc/x was a bare FileNotFoundError
    writable_folder(folder, "trace")


def _clear_old_steps(folder: Path) -> None:
    """Take away the step traces an earlier navigation left in ``folder``: a navigation of
    2 steps into the folder of one of 4 left ``step-003.jsonl`` and ``step-004.jsonl``
    beside its own ``navigation.jsonl``, read as its steps."""
    for path in folder.glob("step-*.jsonl"):
        if _STEP_FILE.fullmatch(path.name) and path.is_file():
            with contextlib.suppress(FileNotFoundError):
                path.unlink()


_STEP_FILE = re.compile(r"step-\d{3,}\.jsonl")


def _network(value: Any, what: str) -> Any:
    from pirate_bt.pipes import Network, NetworkSpec, load_network

    if isinstance(value, Network):
        return value
    if isinstance(value, NetworkSpec):  # as simulate_mission takes it
        return Network(value, f"<{value.name}>")
    if not isinstance(value, str | Path):
        raise InputError(
            f"{what}: give a network name, a file, a NetworkSpec or a Network, not {shown(value)}"
        )
    return load_network(network_name(value, what))


def _check_next_step(navigator: Any) -> str:
    """``navigator``'s class name (one printable line, bounded: one of 1 MB, or with a
    newline, was every message's and the result's summary's) once its ``next_step`` is
    a plain method ``next_step(obs)`` can call.

    Raises:
        InputError: no such method, an ``async def`` or a generator (its answer was
            refused only after connecting), or one of the wrong arity (a bare
            ``TypeError`` once connected: *navigator 'N' raised TypeError:
            N.next_step() takes 1 positional argument but 2 were given*).
    """
    kind = one_line(type(navigator).__name__, 80)
    decide = navigator_method(navigator, "next_step", kind)
    if not callable(decide):
        raise InputError(f"navigate: {shown(navigator)} has no next_step(obs) method")
    never = never_runs(decide)  # its own, or a callable object's __call__ (that connected)
    if never == "an async def":
        raise InputError(
            f"navigate: {kind}.next_step is async def; write it as"
            " a plain def that returns a Step, or None when done"
        )
    if never is not None:  # a yield in it: it returns a generator
        raise InputError(
            f"navigate: {kind}.next_step yields; write it to return a Step, or None when done"
        )
    signature = uncallable_with(decide, 1)
    if signature is not None:
        signature = signature.replace(return_annotation=inspect.Signature.empty)
        raise ArgumentTypeError(
            f"navigate: {kind}.next_step{signature} cannot be called as next_step(obs);"
            " give it one argument, the observation"[:300]
        )
    return kind


@one_run_in_process("navigate")
def navigate(
    navigator: Navigator | str,
    *,
    sim: Any = None,
    port: str | Path | None = None,
    map: Any = None,
    params: Mapping[str, Any] | None = None,
    seed: int = 0,
    faults: str | Iterable[str] | None = None,
    trace: str | Path | None = None,
    robot: Any = None,
    max_time: str | float = "3600 s",
    rate: str | float = "20 Hz",
    deadline: str | float = "5 s",
    max_steps: int = 500,
    map_tolerance: float = MAP_FRACTION,
    firmware: bool = False,
) -> NavigationResult:
    """Drive the robot step by step, each step chosen by ``navigator`` from what it felt.

    Args:
        navigator: An object with ``next_step(obs) -> Step | None`` (an instance,
            not its class), or the name of a built-in or installed navigator
            (``"route"``, ``"goal"``) made with ``params``.
        sim: The simulator's network, the pipe as it really is (a bundled name, a
            file, a ``NetworkSpec`` or a ``Network``; the default when no ``port`` is
            given: the map, as a mission's truth is, else ``"straight"``).
        port: A real robot (serial port or pyserial URL) instead of the simulator.
        map: The map the navigator and the planner see, given as ``sim`` is
            (``None``: no map; the belief is then the odometry's distance along the
            way).
        params: The navigator's parameters when it is given by name
            (``{"segment": "run-d"}``).
        seed: The simulator's seed.
        faults: Simulator and link faults, as for :func:`pirate_bt.simulate_tree`.
        trace: A directory for ``navigation.jsonl`` (every decision with its
            observation) and one tick trace per step (``step-001.jsonl``, ...).
        robot: The robot description (default: bundled).
        max_time: Clock time the whole navigation may take: above 0 and at most 1e9 s
            (``nan`` and ``inf`` are refused: a navigation with no finite limit could
            run for ever).
        rate: Tick rate: above 0, at most 1000 Hz, a tick within ``max_time``.
        deadline: Wall time the navigator may take for one decision (``"5 s"``):
            above 0 and at most a day (``nan`` and ``inf`` are refused).
        max_steps: Steps the navigation may take (1 to 1,000,000).
        map_tolerance: How far the map's lengths may be off (see
            :func:`pirate_bt.simulate_mission`).
        firmware: Simulator only: run it through the real firmwares in simavr.

    Returns:
        NavigationResult: How it went; a failed navigation is a result, not an
            exception. ``why`` names the failing step's cause, a map disagreement
            (the first one, when the navigator went on after it), or the navigator's
            own error; a success the simulator judged unsafe says so.

    Raises:
        InputError: an unknown navigator or parameter, a navigator by name whose
            making raised (named with where it raised), a bad option, a map or
            network that does not load, a navigator class given instead of an
            instance, or a map the navigator's ``check_map`` refuses or fails on.
        LinkError: the robot cannot be reached.

    Example::

        import pirate_bt
        from pirate_bt import Step

        class ThreeMetres:
            def next_step(self, obs):
                return Step("straight", distance="1 m") if obs.step < 3 else None

        result = pirate_bt.navigate(ThreeMetres(), sim="straight")
        print(result.summary())
    """
    if sim is not None and port is not None:
        raise InputError("navigate: give sim= or port=, not both")
    if port is not None:
        port = port_url(port)
    max_steps = plain_number(max_steps)
    if isinstance(max_steps, bool) or not isinstance(max_steps, int):
        raise InputError(f"max_steps must be a positive whole number, not {max_steps!r}"[:200])
    if not 1 <= max_steps <= MAX_STEPS:
        raise InputError(f"max_steps: give 1 to {MAX_STEPS:,}, not {max_steps}"[:200])
    max_time_s = positive_time_s(max_time, "max_time", instead=NO_LIMIT)
    period_s = tick_period_s(rate, max_time_s)
    deadline_s = positive_time_s(
        deadline, "deadline", limit_s=MAX_DEADLINE_S, instead="give a wall time such as '5 s'"
    )
    fraction(map_tolerance, "map_tolerance")
    seed = seed_value(seed)
    faults = fault_list(faults)  # a generator: read once, checked and then run
    split_faults(faults)
    if trace is not None:  # its name now; the folder is made once every argument is checked
        _not_a_trace_file(trace)
    if isinstance(navigator, str):
        name = navigator
        navigator = load_navigator(navigator, params_mapping(params))
        _check_next_step(navigator)  # a plug-in's, before anything connects
    else:
        if params:
            raise InputError("navigate: params= is for a navigator given by name")
        if isinstance(navigator, type):  # its next_step would be called unbound
            cls = one_line(navigator.__name__, 80)
            raise InputError(f"navigate: give an instance of {cls} ({cls}(...)), not the class")
        name = builtin_name(navigator) or _check_next_step(navigator)
    description = load_robot_like(robot)
    map_network = _network(map, "map") if map is not None else None
    target: Any
    if port is not None:
        target = port
    else:
        # no sim= with a map: the pipe is as drawn (a mission's truth, a campaign's
        # world); it was the bundled straight, so a map of the lab ran in 5 m of pipe
        world = sim if sim is not None else map if map is not None else "straight"
        target = _network(world, "sim")
        if target is map_network:  # the simulator's own: nothing the navigation does to it
            target = copy.deepcopy(target)
    # before anything moves, on a copy: a check_map that mutates the map changes nothing
    check_navigator_map(navigator, name, copy.deepcopy(map_network), deadline_s)
    if map_network is not None:  # every step would be refused, the first after connecting
        check_map_start(map_network, description, name)
    # every argument checked: an unknown navigator makes no folder; one refused at
    # connect (a fault's unknown target, a port that does not answer) leaves none made
    # on the way to it either (the trace folder alone was taken away: x/y left x)
    folder = _trace_folder(trace) if trace is not None else None
    with new_folders_undone(folder) if folder is not None else contextlib.nullcontext():
        if folder is not None:
            _make_trace_folder(folder)
        connection = connect(target, robot=description, seed=seed, faults=faults, firmware=firmware)
    with connection:
        if folder is not None:
            _clear_old_steps(folder)
        simulator = connection.simulator
        truth_for = None
        truth_now = None
        if simulator is not None:
            from pirate_bt.task.mission import truth_of

            start = float(simulator.model.s_m)
            truth_for = (lambda plan: truth_of(plan, simulator)) if map_network else None
            truth_now = lambda: float(simulator.model.s_m) - start  # noqa: E731
        result = run_navigation(
            navigator,
            description,
            connection.supervisor,
            connection.clock,
            name=name,
            network=map_network,
            truth_for=truth_for,
            truth_now=truth_now,
            counters=simulator.counters if simulator is not None else None,
            trace_dir=Path(trace) if trace is not None else None,
            period_s=period_s,
            max_time_s=max_time_s,
            deadline_s=deadline_s,
            max_steps=max_steps,
            map_tolerance=map_tolerance,
            scenario=connection.target,
            seed=connection.seed,
            count_from_open=True,  # as a tree run: a slide as the robot was put in counts
        )
        if not result.succeeded:  # a step stopped half-way may leave one half free
            held = hold_both(description, connection.supervisor, connection.clock)
            if held is not None:
                result.notes.append(f"after the stop, {held}")
    if connection.close_error is not None:  # the robot stopped? (api.results.after_close)
        result.why = closing_why(result.succeeded, result.why, connection.close_error)
        result.status = "failure"
        result.close_error = connection.close_error
    return result

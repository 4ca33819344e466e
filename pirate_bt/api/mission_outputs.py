"""Write a mission's outputs: :func:`write_mission_outputs` (plots, tree diagrams, report).

Split from :mod:`pirate_bt.api.missions`, which runs the mission and calls this when
given an ``output`` folder; planner code calls it on a result of its own.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from pirate_bt.api.observing import check_callback
from pirate_bt.api.options import kind_of, output_folder, plain_number, report_extras
from pirate_bt.errors import InputError

__all__ = ["OUTPUT_NAMES", "OutputsNotWritten", "outputs_not_inputs", "write_mission_outputs"]

OUTPUT_NAMES = (
    "plot.png",
    "belief.png",
    "tree.svg",
    "tree.dot",
    "coverage.svg",
    "coverage.dot",
    "report.md",
    "report.html",
)
"""The files :func:`write_mission_outputs` writes into its folder (the trace aside)."""


def outputs_not_inputs(
    folder: str | Path, option: str, inputs: dict[str, Any], *, trace_there: bool
) -> None:
    """A mission's output ``folder`` never writes over its own files, before the run: a
    route kept as ``DIR/report.md`` was replaced by the report, exit 0. ``trace_there``:
    the trace goes into the folder too (``trace.jsonl``).

    Raises:
        InputError: a file the mission writes in ``folder`` is one of ``inputs``.
    """
    from pirate_bt.api.options import not_an_input

    for name in ("trace.jsonl", *OUTPUT_NAMES) if trace_there else OUTPUT_NAMES:
        try:
            not_an_input(Path(folder) / name, option, inputs)
        except InputError as exc:
            said = str(exc).removesuffix("; name another file")
            raise InputError(
                f"{said}, where the mission writes its {name}; name another folder"
            ) from None


class OutputsNotWritten(InputError):
    """A mission ran, but its report could not be written (``output=`` of
    :func:`~pirate_bt.api.missions.simulate_mission` and
    :func:`~pirate_bt.api.missions.run_mission`): the message names the file and then
    the mission's own line with its first cause, and :attr:`result` holds the
    mission's result, which a bare ``OSError`` lost."""

    def __init__(self, message: str, result: Any) -> None:
        super().__init__(message)
        self.result = result
        """The :class:`~pirate_bt.task.mission_result.MissionResult` of the run."""


def write_mission_outputs(
    result: Any,
    output: str | Path,
    *,
    wall_s: float | None = None,
    extra_sections: Sequence[tuple[str, list[str]]] = (),
    extra_pictures: Sequence[tuple[str, str]] = (),
    warn: Callable[[str], None] | None = None,
    option: str = "output",
) -> list[Path]:
    """Write a mission's plots, tree diagram and report (``report.md``, ``report.html``).

    A plot or diagram that cannot be made (no Graphviz ``dot``, no matplotlib, a full
    disk) is reported through ``warn``, naming the file, and left out: nothing of it is
    left half-written. The report is always written, whole or not at all. ``option``
    is how the caller's user named ``output`` (a command's ``--output``): the
    messages name it.

    Returns:
        The files written (the trace first, when there is one).

    Raises:
        InputError: ``output`` is no folder that takes files, or the report cannot be
            written (``output: cannot write OUT/report.md: No space left on device``),
            named ``option``.
    """
    import logging

    log = warn or logging.getLogger("pirate_bt.api").warning
    from pirate_bt.task.mission import MissionResult
    from pirate_bt.task.report import plot_belief, write_report

    if not isinstance(result, MissionResult):
        raise InputError(f"result: give a MissionResult, not {kind_of(result)}")
    wall_s = plain_number(wall_s)  # a NumPy number is seconds too (it was refused)
    extra_pictures = _picture_names(extra_pictures)  # a Path is a file name too
    report_extras(wall_s, extra_sections, extra_pictures, warn)  # before the folder
    check_callback(warn, "warn", "warn(message)", 1)  # a lambda: None failed as it warned
    if not isinstance(option, str) or not option:
        raise InputError(f"option: give the name of the output option, not {kind_of(option)}")
    out = output_folder(output, option)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{option}: cannot make the folder {out}: {exc.strerror or exc}") from None
    files: list[Path] = []
    pictures: list[tuple[str, str]] = []
    if result.trace_path is not None and result.trace_path.exists():
        files.append(result.trace_path)
        try:
            from pirate_bt.render.plot import plot_trace
            from pirate_bt.trace import read_trace

            plotted = plot_trace(read_trace(result.trace_path), out / "plot.png")
            files.append(plotted)
            pictures.append(("Joints, clamps and speed", plotted.name))
        except OSError as exc:  # as the belief plot's: "FILE: why", not "[Errno 28] ..."
            log(f"no trace plot: {_os_error(exc)}")
        except Exception as exc:  # a missing plot must not lose the report
            log(f"no trace plot: {exc}")
    try:
        belief = plot_belief(result, out / "belief.png")
    except OSError as exc:  # a full disk: it was "No space left on device", no file
        log(f"no belief plot: {_os_error(exc)}")
        belief = None
    if belief is not None:
        files.append(belief)
        pictures.append(("Belief and truth", belief.name))
    try:
        from pirate_bt.render.tree import render_tree

        drawn = render_tree(result.tree, out / "tree.svg", title=result.plan.route.name)
        files.append(drawn)
        pictures.append(("Mission tree", drawn.name))
    except FileNotFoundError as exc:
        log(str(exc))
        dot = out / "tree.dot"
        if dot.exists():
            files.append(dot)
    except OSError as exc:  # the diagram cannot be written: the report still can be
        log(f"no tree diagram: {_os_error(exc)}")
    except InputError as exc:  # its .dot file beside it cannot be written (a full disk)
        log(f"no tree diagram: {_as_option(exc, option)}")
    if result.coverage is not None:
        try:
            from pirate_bt.render.tree import render_tree

            drawn = render_tree(result.tree, out / "coverage.svg", coverage=result.coverage)
            files.append(drawn)
            pictures.append(("Coverage (how often each node ran)", drawn.name))
        except FileNotFoundError:  # no dot: said once above; coverage.dot stays, listed
            dot = out / "coverage.dot"
            if dot.exists():
                files.append(dot)
        except OSError as exc:
            log(f"no coverage diagram: {_os_error(exc)}")
        except InputError as exc:
            log(f"no coverage diagram: {_as_option(exc, option)}")
    try:
        files += write_report(
            result, out, [*pictures, *extra_pictures], list(extra_sections), wall_s or result.wall_s
        )
    except OSError as exc:
        raise InputError(f"{option}: cannot write {_os_error(exc)}") from None
    return files


def _picture_names(pictures: Any) -> Any:
    """``extra_pictures`` with each file name given as a path (``Path("scan.png")``) as
    its text, which the report links to; anything else as it is, for
    :func:`~pirate_bt.api.options.report_extras` to take or refuse (a ``Path`` was
    refused, *each item is a (caption, file name) pair*)."""
    if isinstance(pictures, str | bytes) or not isinstance(pictures, Sequence):
        return pictures
    return [
        (item[0], os.fspath(item[1]))
        if isinstance(item, tuple | list) and len(item) == 2 and isinstance(item[1], os.PathLike)
        else item
        for item in pictures
    ]


def _as_option(exc: InputError, option: str) -> str:
    """A diagram's error in the caller's words: ``render_tree`` names its own parameter
    (``out: cannot write 'OUT/tree.dot': ...``), which nobody calling this gave."""
    text = str(exc)
    return f"{option}: {text.removeprefix('out: ')}" if text.startswith("out: ") else text


def _os_error(exc: OSError) -> str:
    """``FILE: why`` for an output that could not be written."""
    why = exc.strerror or str(exc) or type(exc).__name__
    return f"{exc.filename}: {why}" if exc.filename is not None else why

"""Write a mission's outputs: :func:`write_mission_outputs` (plots, tree diagrams, report).

Split from :mod:`pirate_bt.api.missions`, which runs the mission and calls this when
given an ``output`` folder; planner code calls it on a result of its own.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from pirate_bt.api.options import kind_of, output_folder, report_extras

__all__ = ["write_mission_outputs"]


def write_mission_outputs(
    result: Any,
    output: str | Path,
    *,
    wall_s: float | None = None,
    extra_sections: Sequence[tuple[str, list[str]]] = (),
    extra_pictures: Sequence[tuple[str, str]] = (),
    warn: Callable[[str], None] | None = None,
) -> list[Path]:
    """Write a mission's plots, tree diagram and report (``report.md``, ``report.html``).

    A plot or diagram that cannot be made (no Graphviz ``dot``, no matplotlib) is
    reported through ``warn`` and left out; the report is always written.

    Returns:
        The files written (the trace first, when there is one).
    """
    import logging

    log = warn or logging.getLogger("pirate_bt.api").warning
    from pirate_bt.errors import InputError
    from pirate_bt.task.mission import MissionResult
    from pirate_bt.task.report import plot_belief, write_report

    if not isinstance(result, MissionResult):
        raise InputError(f"result: give a MissionResult, not {kind_of(result)}")
    report_extras(wall_s, extra_sections, extra_pictures, warn)  # before the folder
    out = output_folder(output)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"output: cannot make the folder {out}: {exc.strerror or exc}") from None
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
        except Exception as exc:  # a missing plot must not lose the report
            log(f"no trace plot: {exc}")
    belief = plot_belief(result, out / "belief.png")
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
    files += write_report(
        result, out, [*pictures, *extra_pictures], list(extra_sections), wall_s or result.wall_s
    )
    return files

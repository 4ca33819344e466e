"""The mission report: what was asked, what happened, and the pictures, as Markdown and HTML.

:func:`write_report` writes ``report.md`` and ``report.html`` into an output
folder that already holds the run's pictures (trace plot, tree diagram, belief
plot, robot diagram). The report has: the route and the network, the outcome
and its reason, the plan (one line per PAB), the timeline (when each PAB
started, with belief and truth), distances, simulator counters (faults,
violations, slips), the localiser's fixes and belief error against the stated
bounds, and extra sections handed in by the caller (the robot's board table).

The HTML is generated from the same lines with no template engine: tables and
pictures only, so it opens anywhere.
"""

from __future__ import annotations

import html
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import IO

from pirate_bt.atomic import write_atomically
from pirate_bt.task.localise import DRIFT_PER_M, FIX_BOUND_M
from pirate_bt.task.mission import MissionResult
from pirate_bt.task.planner import MissionPlan
from pirate_bt.trace.coverage import GUARDS, Coverage

__all__ = ["coverage_section", "plot_belief", "report_lines", "write_report"]


def _table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    return out


def _m(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f} m"


def plan_lines(plan: MissionPlan) -> list[str]:
    """The plan as a Markdown table."""
    rows = [
        (i, p.note, f"{p.start_m:.2f}", f"{p.end_m:.2f}", p.step.line, p.step.text)
        for i, p in enumerate(plan.pabs, start=1)
    ]
    return _table(("#", "PAB", "from (m)", "to (m)", "line", "route command"), rows)


def map_and_pipe_lines(result: MissionResult) -> list[str]:
    """Where map and pipe differed: the disagreement, re-planned legs, slopes not as
    drawn, fix corrections."""
    lines = ["", "## Map and pipe", ""]
    d = result.disagreement
    if d is not None:
        lines += [
            "Belief and map **disagreed**; the mission stopped in the safe state.",
            "",
            f"- **Where:** {d.belief_m:.2f} m along the map (believed),"
            f" {d.time_s - result.start_s:.1f} s into the run",
            f"- **Map expected:** {d.expected or 'no feature'} (searched within"
            f" {d.window_m:.2f} m)",
            f"- **Robot sensed:** {d.sensed or 'nothing'}",
            f"- **Evidence:** {d.evidence}",
            "",
        ]
    for note in result.replans:
        after, held, rest = note.partition("after the stop, ")
        lines += [
            f"- **After the stop:** {rest}" if held and not after else f"- **Re-planned:** {note}"
        ]
    if result.replans:
        lines.append("")
    for note in result.map_notes:
        lines.append(f"- **Not as drawn:** {note}")
    if result.map_notes:
        lines.append("")
    shortened = [leg for leg in result.legs if leg.why]
    if shortened:
        lines.append(
            "Legs whose distance, re-computed from the belief when they started, differs"
            " from the plan:"
        )
        lines.append("")
        lines += _table(
            ("leg", "planned", "driven", "from (belief)", "why"),
            [
                (leg.label, _m(leg.planned_m), _m(leg.driven_m), _m(leg.belief_m), leg.why)
                for leg in shortened
            ],
        )
        lines.append("")
    if result.fixes:
        worst = max(result.fixes, key=lambda f: abs(f.correction_m))
        lines.append(
            f"Largest correction at a feature: {worst.correction_m:+.3f} m at"
            f" {worst.feature!r} (the pipe before it differs from the map by about that much,"
            " plus odometry drift)."
        )
        least = min(result.fixes, key=lambda f: f.confidence)
        if least.confidence < 0.5:
            lines.append(
                f"Matched on the map's order beyond its tolerance: {least.feature!r}"
                f" ({least.drift_per_m * 100:+.0f} % of the {least.since_fix_m:.2f} m driven"
                f" since the fix before; confidence {least.confidence:.2f})."
            )
    elif d is None:
        lines.append("No feature fix, no disagreement.")
    return lines


def report_lines(
    result: MissionResult,
    pictures: Sequence[tuple[str, str]] = (),
    extra: Sequence[tuple[str, list[str]]] = (),
    wall_time_s: float | None = None,
) -> list[str]:
    """The report as Markdown lines.

    Args:
        result: The mission's result.
        pictures: ``(title, file name)`` of pictures in the same folder.
        extra: ``(heading, markdown lines)`` sections to append.
        wall_time_s: Wall time of the run, for the speed-up.
    """
    plan = result.plan
    run = result.run
    outcome = "SUCCESS" if result.succeeded else "FAILED"
    lines = [
        f"# Mission report: {plan.route.name}",
        "",
        f"- **Outcome:** {outcome} - {result.why or result.reason}",
        f"- **Route:** `{plan.route.source}` ({len(plan.route.steps)} commands)",
        f"- **Network:** {plan.network.name} ({plan.network.total_length_m():.1f} m of pipe;"
        f" path taken {plan.path.length_m:.1f} m: {' > '.join(plan.path.segments)})",
        f"- **Planned:** {len(plan.pabs)} PABs, {plan.distance_m:.2f} m of driving,"
        f" front tip from {plan.start_m:.2f} m to {plan.end_m:.2f} m",
        f"- **Time:** {run.sim_time_s:.1f} s on the clock, {run.ticks} ticks"
        + (
            f", {wall_time_s:.1f} s wall ({run.sim_time_s / wall_time_s:.0f}x real time)"
            if wall_time_s
            else ""
        ),
        f"- **Distance:** {result.odometry_m:.2f} m by odometry"
        + (
            f", {result.sim['distance_m']:.2f} m in the simulator"
            if "distance_m" in result.sim
            else ""
        ),
        f"- **Where:** believed {_m(result.belief_m)}, truly {_m(result.truth_m)}"
        f" (error {_m(result.final_error_m, 3)})",
    ]
    if result.mismatch:
        lines.append(f"- **Map mismatch:** {result.mismatch}")
    failing = result.failing_node or run.failing_node
    if failing:
        lines.append(f"- **Failing node:** `{failing}`")
    c = result.counters
    lines.append(
        f"- **Counters:** {c.refusals} refused, {c.clips} clipped, {c.safe_states} safe states;"
        f" link: {c.retries} retries, {c.link_failures} failed, {c.crc_errors} CRC errors"
        + (
            f"; simulator: {c.violations} violations, {c.damage} damage"
            if result.truth_m is not None
            else ""
        )
    )
    lines += ["", "## Route", "", "```text"]
    lines += [f"{s.line:3d}  {s.text}" for s in plan.route.steps]
    lines += ["```", "", "## Plan", "", *plan_lines(plan)]
    if result.pabs:
        lines += ["", "## PABs", ""]
        lines += _table(
            ("step", "kind", "outcome", "start (s)", "end (s)", "why"),
            [
                (
                    p.label,
                    p.kind,
                    p.outcome,
                    "" if p.start_s is None else f"{p.start_s:.1f}",
                    "" if p.end_s is None else f"{p.end_s:.1f}",
                    (p.why + (f" (at `{p.failing_node}`)" if p.failing_node else "")).replace(
                        "|", "/"
                    ),
                )
                for p in result.pabs
            ],
        )
    lines += ["", "## Timeline", ""]
    lines += _table(
        ("time (s)", "step", "belief (m)", "truth (m)"),
        [
            (f"{e.time_s:.1f}", e.label, f"{e.belief_m:.2f}", _m(e.truth_m).removesuffix(" m"))
            for e in result.timeline
        ],
    )
    lines += ["", "## Localisation", ""]
    lines.append(
        f"Stated bounds: error at most {FIX_BOUND_M:.2f} m right after a feature fix, growing by"
        f" at most {DRIFT_PER_M * 100:.0f} cm per metre driven between fixes."
    )
    lines.append("")
    if result.fixes:
        lines += _table(
            (
                "time (s)",
                "feature",
                "by",
                "belief before",
                "after",
                "truth",
                "error after",
                "drift per m",
                "confidence",
            ),
            [
                (
                    f"{f.time_s - result.start_s:.1f}",
                    f.feature,
                    f.how,
                    _m(f.before_m, 3),
                    _m(f.after_m, 3),
                    _m(f.truth_m, 3),
                    _m(f.error_after_m, 3),
                    f"{f.drift_per_m * 100:+.1f} %",
                    f"{f.confidence:.2f}",
                )
                for f in result.fixes
            ],
        )
    else:
        lines.append("No feature was recognised.")
    lines += [
        "",
        f"Largest error after a fix: {_m(result.max_fix_error_m, 3)};"
        f" largest error over the run: {_m(result.max_error_m, 3)}.",
    ]
    lines += map_and_pipe_lines(result)
    if result.sim:
        lines += ["", "## Simulator counters", ""]
        lines += _table(("counter", "value"), [(k, f"{v:g}") for k, v in result.sim.items()])
    if result.coverage is not None:
        lines += coverage_section(result.coverage)
    for title, name in pictures:
        lines += ["", f"## {title}", "", f"![{title}]({name})"]
    for heading, body in extra:
        lines += ["", f"## {heading}", "", *body]
    return [*lines, ""]


def coverage_section(coverage: Coverage, limit: int = 20) -> list[str]:
    """The report's coverage section: how many nodes ran, which never did, which guards
    never failed (per node as BT.CPP's ``TreeObserver`` counts; see
    :mod:`pirate_bt.trace.coverage`)."""
    lines = ["", "## Coverage", "", f"{coverage.summary()}."]
    for title, found in (
        ("Never ran", coverage.never_ran()),
        ("Guards and conditions that never failed", coverage.never_failed(GUARDS)),
    ):
        if not found:
            continue
        lines += ["", f"{title} ({len(found)}):", ""]
        lines += [f"- `{n.path}`" for n in found[:limit]]
        if len(found) > limit:
            lines.append(f"- ... and {len(found) - limit} more")
    return lines


def _inline(text: str) -> str:
    out = html.escape(text)
    parts = out.split("**")
    out = "".join(f"<b>{p}</b>" if i % 2 else p for i, p in enumerate(parts))
    parts = out.split("`")
    return "".join(f"<code>{p}</code>" if i % 2 else p for i, p in enumerate(parts))


def markdown_to_html(lines: Sequence[str], title: str) -> str:
    """The small subset of Markdown the report uses, as one HTML page."""
    body: list[str] = []
    in_code = in_list = False
    table: list[list[str]] = []

    def flush_table() -> None:
        if not table:
            return
        body.append("<table>")
        for i, row in enumerate(table):
            if i == 1:
                continue
            tag = "th" if i == 0 else "td"
            body.append("<tr>" + "".join(f"<{tag}>{_inline(c)}</{tag}>" for c in row) + "</tr>")
        body.append("</table>")
        table.clear()

    for line in lines:
        if line.startswith("```"):
            body.append("</pre>" if in_code else "<pre>")
            in_code = not in_code
            continue
        if in_code:
            body.append(html.escape(line))
            continue
        if line.startswith("|"):
            table.append([c.strip().replace("\\|", "|") for c in line.strip("|").split(" | ")])
            continue
        flush_table()
        if line.startswith("- "):
            if not in_list:
                body.append("<ul>")
                in_list = True
            body.append(f"<li>{_inline(line[2:])}</li>")
            continue
        if in_list:
            body.append("</ul>")
            in_list = False
        if line.startswith("#"):
            level = len(line) - len(line.lstrip("#"))
            body.append(f"<h{level}>{_inline(line[level:].strip())}</h{level}>")
        elif line.startswith("!["):
            alt, _, rest = line[2:].partition("](")
            body.append(
                f'<p><img src="{html.escape(rest.rstrip(")"))}" alt="{html.escape(alt)}"></p>'
            )
        elif line.strip():
            body.append(f"<p>{_inline(line)}</p>")
    flush_table()
    if in_list:
        body.append("</ul>")
    style = (
        "body{font-family:sans-serif;max-width:70em;margin:2em auto;padding:0 1em}"
        "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;"
        "font-size:90%}img{max-width:100%}pre{background:#f4f4f4;padding:1em}"
    )
    return (
        f"<!doctype html>\n<html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n"
    )


def plot_belief(result: MissionResult, out: Path) -> Path | None:
    """Belief and truth along the pipe over time, and their difference (PNG).

    Returns:
        ``out``, or ``None`` when matplotlib is missing or there is nothing to draw.
    """
    if not result.samples:
        return None
    try:
        from pirate_bt.render.plot import import_matplotlib

        import_matplotlib().use("Agg")  # whatever MPLBACKEND names
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    t = [s.time_s for s in result.samples]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    ax1.plot(t, [s.belief_m for s in result.samples], label="belief")
    if any(s.truth_m is not None for s in result.samples):
        ax1.plot(
            t,
            [s.truth_m if s.truth_m is not None else float("nan") for s in result.samples],
            "--",
            label="truth (simulator)",
        )
        ax2.plot(
            t,
            [
                s.belief_m - s.truth_m if s.truth_m is not None else float("nan")
                for s in result.samples
            ],
            color="tab:red",
        )
        ax2.axhline(FIX_BOUND_M, color="grey", lw=0.8, ls=":")
        ax2.axhline(-FIX_BOUND_M, color="grey", lw=0.8, ls=":")
    for fix in result.fixes:
        for ax in (ax1, ax2):
            ax.axvline(fix.time_s - result.start_s, color="tab:green", lw=0.6)
    ax1.set_ylabel("front tip (m)")
    ax1.legend(loc="upper left")
    ax2.set_ylabel("belief - truth (m)")
    ax2.set_xlabel("time (s); green: feature fixes")
    # the route's name as written, never as mathtext (a '$' in a file name made
    # matplotlib parse it, and a stray '\frac' ended the mission with an internal error)
    fig.suptitle(f"Localisation: {result.plan.route.name}", parse_math=False)
    try:
        fig.tight_layout()
        # whole or not at all, named by the picture (a full disk left a 0-byte belief.png
        # and said "No space left on device" with no file)
        write_whole(out, lambda stream: fig.savefig(stream, format="png"))
    finally:
        plt.close(fig)
    return out


def write_whole(out: Path, fill: Callable[[IO[bytes]], object]) -> None:
    """Write ``out`` whole or not at all (:func:`pirate_bt.atomic.write_atomically`);
    an ``OSError`` names ``out``, not the temporary file beside it."""
    try:
        write_atomically(out, fill)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(out)) from exc


def write_report(
    result: MissionResult,
    out_dir: Path,
    pictures: Sequence[tuple[str, str]] = (),
    extra: Sequence[tuple[str, list[str]]] = (),
    wall_time_s: float | None = None,
) -> list[Path]:
    """Write ``report.md`` and ``report.html`` into ``out_dir``.

    Returns:
        The files written.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    lines = report_lines(result, pictures, extra, wall_time_s)
    md = out_dir / "report.md"
    text = "\n".join(lines).encode("utf-8")
    write_whole(md, lambda stream: stream.write(text))
    page = out_dir / "report.html"
    html_text = markdown_to_html(lines, f"Mission {result.plan.route.name}").encode("utf-8")
    write_whole(page, lambda stream: stream.write(html_text))
    return [md, page]

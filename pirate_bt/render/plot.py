"""Plot a run from its trace: joints, clamps, speed and rotation over time.

Four panels share the time axis: bend joint angles (deg), clamp (spring)
forces (N), mean wheel speed (mm/s) and the rotation between the halves (deg).

Behind them the run is shaded by **PAB**, named in a strip above the panels.
Steps are the nodes marked ``pab_step`` (or else the children of the root); a
PAB is a child of the nodes that hold all the steps (a mission's route
sequence holds one child per PAB; a single PAB's tree has its steps as PABs).
A label is written only where it fits: in full, else as the PAB's number
(listed under the plot), else not at all, so the plot stays legible at any
mission length. A zoomed plot (``start_s``/``end_s``) adds a second strip with
the finer steps, labelled by the same rule.

The series are built in one pass over the trace's change records (not over
rebuilt frames): each tick costs a dictionary update and one row of values.

matplotlib is optional (the ``plot`` extra). It is imported only inside
:func:`plot_trace`, with the non-interactive Agg backend, so nothing else in the
library pays for it.
"""

from __future__ import annotations

import io
import math
import numbers
import os
import sys
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pirate_bt.errors import ArgumentTypeError, ConfigurationError, InputError
from pirate_bt.render.files import write_file
from pirate_bt.trace.reader import Trace, read_trace
from pirate_bt.trace.structure import NodeInfo, TreeStructure
from pirate_bt.trace.text import one_line

__all__ = [
    "PlotSeries",
    "StepSpan",
    "import_matplotlib",
    "pab_nodes",
    "plot_series",
    "plot_trace",
    "strip_labels",
]

_PANELS = (
    ("joint_angle_rad.", "joint angle (deg)", 180.0 / math.pi),
    ("clamp_force_n.", "clamp force (N)", 1.0),
    ("speed", "speed (mm/s)", 1000.0),
    ("rotation_rad", "rotation (deg)", 180.0 / math.pi),
)
_STEP_COLOURS = ("#dbeafe", "#dcfce7", "#fef3c7", "#fce7f3", "#e0e7ff", "#ccfbf1")
_LABEL_PT = 7.0
# Width of one character of the label font, in points (a generous average).
_CHAR_PT = 0.62 * _LABEL_PT
_LEGEND_LINES = 8  # the PABs listed under a plot: lines at most
_LEGEND_ENTRY = 80  # characters of one PAB's name there at most


@dataclass(frozen=True)
class StepSpan:
    """A PAB step that was RUNNING from ``start_s`` to ``end_s``."""

    node: str
    name: str
    start_s: float
    end_s: float


@dataclass
class PlotSeries:
    """Time series taken from a trace, in SI units.

    Attributes:
        times: Per series, the times its value changed (within the window; the
            first is the window's start when the value was known before it).
        values: Series by flat state name (``joint_angle_rad.bend_1``), plus
            ``speed`` (mean drive speed in m/s): ``values[k][i]`` holds from
            ``times[k][i]`` until the next change.
        steps: The active PAB steps over time (the finer level).
        pabs: The active PABs over time (the level the plot shades and names).
        start_s: Start of the window.
        end_s: End of the window.
    """

    times: dict[str, list[float]] = field(default_factory=dict)
    values: dict[str, list[float]] = field(default_factory=dict)
    steps: list[StepSpan] = field(default_factory=list)
    pabs: list[StepSpan] = field(default_factory=list)
    start_s: float = 0.0
    end_s: float = 0.0


def _as_float(value: Any) -> float:
    if type(value) is float:
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def pab_nodes(structure: TreeStructure) -> list[NodeInfo]:
    """The PABs of a tree: the children of the steps' deepest common ancestor that hold steps.

    A mission's route sequence holds one child per PAB; in a single PAB's tree
    the steps themselves come out (their common ancestor's children are the steps).
    """
    steps = structure.steps()
    if not steps:
        return []
    chains = [_ancestry(structure, s) for s in steps]
    common = 0
    while all(len(c) > common + 1 for c in chains) and len({c[common] for c in chains}) == 1:
        common += 1
    if len({c[common] for c in chains}) == 1:
        return steps  # one step, or steps nested in one another
    return [structure.node(i) for i in dict.fromkeys(c[common] for c in chains)]


def _ancestry(structure: TreeStructure, node: NodeInfo) -> list[str]:
    """Ids from the root down to ``node``."""
    chain: list[str] = []
    current: str | None = node.id
    while current is not None:
        chain.append(current)
        current = structure.node(current).parent
    return chain[::-1]


class _Spans:
    """Which of a set of nodes is RUNNING, from status changes, as spans over time."""

    def __init__(self, nodes: list[NodeInfo]) -> None:
        self.order = {n.id: i for i, n in enumerate(nodes)}
        self.names = {n.id: one_line(n.name) for n in nodes}  # "\x00": a glyph no font has
        self.running: set[str] = set()
        self.active: tuple[str, float] | None = None
        self.spans: list[StepSpan] = []

    def update(self, status: Any, t_s: float) -> None:
        changed = False
        for node_id, code in status.items():
            if node_id in self.order:
                changed = True
                if code == "R":
                    self.running.add(node_id)
                else:
                    self.running.discard(node_id)
        if not changed:
            return
        first = min(self.running, key=self.order.__getitem__) if self.running else None
        if self.active is not None and self.active[0] != first:
            self.close(t_s)
        if first is not None and self.active is None:
            self.active = (first, t_s)

    def close(self, t_s: float) -> None:
        if self.active is not None:
            node_id, start = self.active
            self.spans.append(StepSpan(node_id, self.names[node_id], start, t_s))
            self.active = None


def _clip(spans: list[StepSpan], start_s: float, end_s: float) -> list[StepSpan]:
    return [
        StepSpan(s.node, s.name, max(s.start_s, start_s), min(s.end_s, end_s))
        for s in spans
        if s.end_s > start_s and s.start_s < end_s
    ]


def plot_series(
    trace: Trace, start_s: float | None = None, end_s: float | None = None
) -> PlotSeries:
    """Collect the series a plot needs from ``trace`` (no matplotlib needed).

    One pass over the trace's change records: a value costs work only when it
    changes, whatever the length of the run.

    Args:
        trace: The trace.
        start_s: Start of the window in seconds of trace time (default: the start).
        end_s: End of the window (default: the end of the trace).
    """
    lo = 0.0 if start_s is None else start_s
    hi = trace.duration_s if end_s is None else end_s
    steps = _Spans(trace.structure.steps())
    pabs = _Spans(pab_nodes(trace.structure))
    times: dict[str, list[float]] = {}
    values: dict[str, list[float]] = {}
    before: dict[str, float] = {}  # the value each key had when the window opens
    drives: dict[str, float] = {}
    speed_t: list[float] = []
    speed_v: list[float] = []
    for tick in trace.ticks:
        t = tick.t_s
        if t > hi:
            break
        if tick.status:
            steps.update(tick.status, t)
            pabs.update(tick.status, t)
        changes = tick.state
        if not changes and not tick.full:
            continue
        if tick.full:
            drives.clear()
        moved = False
        for key, raw in changes.items():
            value = _as_float(raw)
            if key.startswith("drive_velocity_mps."):
                drives[key] = value
                moved = True
            if t < lo:
                before[key] = value
                continue
            column = values.get(key)
            if column is None:
                times[key], values[key] = [t], [value]
            else:
                times[key].append(t)
                column.append(value)
        if moved and drives:
            mean = math.fsum(drives.values()) / len(drives)
            if t < lo:
                before["speed"] = mean
            else:
                speed_t.append(t)
                speed_v.append(mean)
    if speed_t or "speed" in before:
        times["speed"], values["speed"] = speed_t, speed_v
    for key, value in before.items():
        times.setdefault(key, []).insert(0, lo)
        values.setdefault(key, []).insert(0, value)
    steps.close(trace.duration_s)
    pabs.close(trace.duration_s)
    series = PlotSeries(times=times, values=values, start_s=lo, end_s=hi)
    series.steps = _clip(steps.spans, lo, hi)
    series.pabs = _clip(pabs.spans, lo, hi)
    return series


def _fits(text: str, span_s: float, px_per_s: float, dpi: float) -> bool:
    return span_s * px_per_s >= (len(text) * _CHAR_PT + 4) * dpi / 72.0


def _number(name: str, position: int) -> str:
    digits = name.split(" ", 1)[0]
    return digits if digits.isdigit() else str(position)


def strip_labels(
    spans: list[StepSpan], px_per_s: float, dpi: float = 100.0
) -> list[tuple[StepSpan, str | None]]:
    """The label each span gets: its name if it fits, else its number, else nothing.

    A span's number is the one its name starts with (a mission's PABs are named
    ``03 bend right (line 6)``), else its position among the spans.

    Args:
        spans: The spans, in time order.
        px_per_s: Pixels per second of the plot's time axis.
        dpi: The picture's resolution (the label font is sized in points).
    """
    out: list[tuple[StepSpan, str | None]] = []
    for number, span in enumerate(spans, start=1):
        width = max(span.end_s - span.start_s, 1e-6)
        if _fits(span.name, width, px_per_s, dpi):
            out.append((span, span.name))
        elif _fits(short := _number(span.name, number), width, px_per_s, dpi):
            out.append((span, short))
        else:
            out.append((span, None))
    return out


def _strip(ax: Any, spans: list[StepSpan], px_per_s: float, dpi: float, what: str) -> list[str]:
    """Draw ``spans`` as labelled bands on a strip axis; return the legend of numbered ones."""
    ax.set_yticks([])
    ax.set_ylim(0, 1)
    ax.set_ylabel(what, fontsize=8, rotation=0, ha="right", va="center")
    for side in ("top", "right", "left"):
        ax.spines[side].set_visible(False)
    colours: dict[str, str] = {}
    legend: list[str] = []
    for span, label in strip_labels(spans, px_per_s, dpi):
        colour = colours.setdefault(span.node, _STEP_COLOURS[len(colours) % len(_STEP_COLOURS)])
        width = max(span.end_s - span.start_s, 1e-6)
        ax.axvspan(span.start_s, span.start_s + width, color=colour, lw=0)
        ax.axvline(span.start_s, color="0.6", lw=0.5)
        if label is None:
            continue
        if label != span.name:
            legend.append(span.name if span.name.startswith(label) else f"{label} {span.name}")
        middle = span.start_s + width / 2
        ax.text(middle, 0.5, label, ha="center", va="center", fontsize=_LABEL_PT, clip_on=True)
    return legend


def _seconds(given: float) -> float:
    """``given`` as a float; a whole number too large for one is infinite (refused)."""
    try:
        return float(given)
    except OverflowError:
        return math.inf if given > 0 else -math.inf


def plot_trace(
    trace: Trace | str | Path,
    out: str | Path,
    title: str | None = None,
    *,
    start_s: float | None = None,
    end_s: float | None = None,
) -> Path:
    """Draw the joints, clamps, speed and rotation of a run to a PNG (or SVG/PDF) file.

    Args:
        trace: The trace, from :func:`~pirate_bt.trace.reader.read_trace`, or the
            path of a trace file, which is read so.
        out: The picture's path; the format follows the suffix (``.png`` usually).
        title: A title; defaults to the tree's name and outcome.
        start_s: Zoom: the first second of trace time to draw (default: the start).
        end_s: Zoom: the last second (default: the end). A zoomed plot also
            shows the PAB steps.

    Returns:
        ``out`` as a path.

    Raises:
        ConfigurationError: matplotlib is not installed.
        ArgumentTypeError: ``trace`` is neither a ``Trace`` nor a path, or ``start_s``
            or ``end_s`` is no number (``True`` and ``"1"`` are not).
        InputError: the trace file cannot be read (its line and column), the run
            took no time (it ended in its first tick, at 0 s), the window
            is not finite, starts before the trace or after it, or is empty (an end
            past the trace's is cut to it), or ``out`` has no suffix matplotlib writes
            (``.png``, ``.svg``, ``.pdf``...).
        OSError: the picture cannot be written (nothing is left of the attempt: it
            is written whole to a temporary file and renamed).
    """
    if isinstance(trace, str | Path):
        trace = read_trace(trace)
    elif not isinstance(trace, Trace):
        raise ArgumentTypeError(
            f"plot_trace: trace: give a Trace (pirate_bt.read_trace) or the path of a trace"
            f" file, not {type(trace).__name__}"
        )
    window_s: list[float | None] = []
    for option, given in (("start_s", start_s), ("end_s", end_s)):  # "1" failed in format()
        # any real number but a bool, as a plain float: numpy.int64(1) and
        # numpy.float32(2) were refused, numpy.float64 (a float) taken
        if given is not None and (isinstance(given, bool) or not isinstance(given, numbers.Real)):
            raise ArgumentTypeError(
                f"plot_trace: {option}: give a number of seconds, not {type(given).__name__}"
            )
        window_s.append(None if given is None else _seconds(given))
    start_s, end_s = window_s
    duration = trace.duration_s
    if duration <= 0 and start_s is None and end_s is None:  # ended in its first tick
        n = trace.last_tick  # was "plot window from 0 s to 0 s is outside the trace"
        took = f"the run took no time (it ended at tick {n}, at {duration:g} s)"
        raise InputError(f"{trace.path}: nothing to plot: {took if n else 'it holds no tick'}")
    lo = 0.0 if start_s is None else start_s
    hi = duration if end_s is None else end_s
    # each refusal says which: "-5-9.25 s is empty or outside the trace" was said of a
    # window that was neither, and of nan. An end past the trace's is cut to it.
    window = f"plot window from {lo:g} s to {hi:g} s"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise InputError(f"{window}: give finite numbers of seconds")
    if lo < 0:
        raise InputError(f"{window} starts before the trace (0 s to {duration:g} s)")
    if lo >= duration:
        raise InputError(f"{window} is outside the trace (0 s to {duration:g} s)")
    if hi <= lo:
        raise InputError(f"{window} is empty: its end is not after its start")
    hi = min(hi, duration)
    zoomed = start_s is not None or end_s is not None
    try:
        matplotlib = import_matplotlib()
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ConfigurationError(
            "plotting needs matplotlib: pip install 'pirate-bt[plot]'"
        ) from None
    out = Path(out)
    kind = picture_format(out)
    series = plot_series(trace, lo, hi)
    strips = 2 if zoomed and series.steps != series.pabs else 1
    ratios = [0.28] * strips + [1.0] * len(_PANELS)
    dpi = 100.0
    # Names are drawn as written: a node named "$x^2$" is no formula, and "a $\frac{$"
    # made matplotlib's mathtext raise (the plot failed with an internal error).
    with plt.rc_context({"text.parse_math": False}):
        return _draw(trace, series, out, kind, title, (lo, hi), zoomed, strips, ratios, dpi)


def _draw(
    trace: Trace,
    series: PlotSeries,
    out: Path,
    kind: str,
    title: str | None,
    window_s: tuple[float, float],
    zoomed: bool,
    strips: int,
    ratios: list[float],
    dpi: float,
) -> Path:
    import matplotlib.pyplot as plt

    lo, hi = window_s
    fig, all_axes = plt.subplots(
        strips + len(_PANELS),
        1,
        sharex=True,
        figsize=(12, 2.2 + 1.9 * len(_PANELS) + 0.3 * strips),
        dpi=dpi,
        gridspec_kw={"height_ratios": ratios, "hspace": 0.08},
    )
    try:
        axes = all_axes[strips:]
        fig.subplots_adjust(left=0.09, right=0.98, top=0.94)
        plot_px = fig.get_figwidth() * dpi * (0.98 - 0.09)
        px_per_s = plot_px / max(hi - lo, 1e-9)
        legend = _strip(all_axes[0], series.pabs, px_per_s, dpi, "PAB")
        if strips == 2:
            _strip(all_axes[1], series.steps, px_per_s, dpi, "step")
        colours: dict[str, str] = {}
        for span in series.pabs:
            colour = colours.setdefault(span.node, _STEP_COLOURS[len(colours) % len(_STEP_COLOURS)])
            for ax in axes:
                ax.axvspan(span.start_s, max(span.end_s, span.start_s + 1e-6), color=colour, lw=0)
        for ax, (prefix, label, scale) in zip(axes, _PANELS, strict=True):
            keys = sorted(
                k
                for k in series.values
                if k == prefix or (prefix.endswith(".") and k.startswith(prefix))
            )
            for key in keys:
                # Held until the next change, and to the end of the window.
                xs = [*series.times[key], hi]
                ys = [v * scale for v in series.values[key]]
                ys.append(ys[-1])
                ax.plot(
                    xs,
                    ys,
                    lw=1.0,
                    drawstyle="steps-post",
                    label=key.partition(".")[2] or key,
                )
            if not keys or all(math.isnan(v) for k in keys for v in series.values[k]):
                ax.text(0.5, 0.5, "not recorded", transform=ax.transAxes, ha="center", color="0.5")
            elif len(keys) > 1:
                ax.legend(loc="upper right", fontsize=7, ncols=min(4, len(keys)))
            ax.set_ylabel(label, fontsize=9)
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlim(lo, hi)
        axes[-1].set_xlabel("time (s)")
        window = f" ({lo:g}-{hi:g} s)" if zoomed else ""
        name = one_line(trace.structure.name)
        fig.suptitle(title or f"{name}: {trace.outcome}{window}", y=0.99)
        bottom = 0.06
        if legend:
            wrapped = _legend_text(legend, int(plot_px / (_CHAR_PT * dpi / 72.0)))
            lines = wrapped.count("\n") + 1
            height_in = fig.get_figheight()
            bottom = 0.06 + lines * (_LABEL_PT + 3) / 72.0 / height_in
            fig.text(0.09, 0.01, wrapped, fontsize=_LABEL_PT, va="bottom", ha="left")
        fig.subplots_adjust(bottom=bottom)
        picture = io.BytesIO()
        fig.savefig(picture, format=kind)
    finally:
        plt.close(fig)
    return write_file(out, picture.getvalue())


def _legend_text(legend: list[str], width: int) -> str:
    """The PABs listed under a plot, in at most :data:`_LEGEND_LINES` lines of ``width``:
    a list of long names (a 20,000-character one) took more lines than the figure is
    high, and matplotlib refused the layout (*bottom cannot be >= top*)."""
    entries = [e if len(e) <= _LEGEND_ENTRY else e[: _LEGEND_ENTRY - 1] + "…" for e in legend]
    lines = textwrap.wrap("PABs too short to name here: " + "   ".join(entries), width=width)
    if len(lines) > _LEGEND_LINES:
        lines = [*lines[: _LEGEND_LINES - 1], "… (more than fit here)"]
    return "\n".join(lines)


def import_matplotlib() -> Any:
    """matplotlib, imported whatever ``MPLBACKEND`` says: a plot is drawn with Agg, and a
    name matplotlib does not know there (``MPLBACKEND=bogus``) made its import raise
    (the plot here, the mission's and the campaign's reports: the first one in a
    process imports it)."""
    if "matplotlib" in sys.modules:
        return sys.modules["matplotlib"]
    screen = os.environ.pop("MPLBACKEND", None)
    try:
        import matplotlib
    finally:
        if screen is not None:
            os.environ["MPLBACKEND"] = screen
    return matplotlib


def picture_format(out: Path) -> str:
    """The picture format matplotlib writes for ``out``'s suffix.

    Raises:
        InputError: no suffix, or one matplotlib does not write.
    """
    from matplotlib.backend_bases import FigureCanvasBase

    known = FigureCanvasBase.get_supported_filetypes()
    kind = out.suffix.lower()[1:]
    if kind not in known:
        raise InputError(
            f"{out}: cannot plot to {out.suffix or 'a name without a suffix'};"
            f" use .png or .svg (or {', '.join('.' + k for k in sorted(known))})"
        )
    return kind

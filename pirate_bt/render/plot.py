"""Plot a run from its trace: joints, clamps, speed and rotation over time.

Four panels share the time axis: bend joint angles (deg), clamp (spring)
forces (N), mean wheel speed (mm/s) and the rotation between the halves (deg).
Behind them, the active PAB step is shaded: the step node that was RUNNING at
each moment, where steps are the nodes marked ``pab_step`` or else the
children of the root (a PAB tree is a root sequence of steps).

matplotlib is optional (the ``plot`` extra). It is imported only inside
:func:`plot_trace`, with the non-interactive Agg backend, so nothing else in the
library pays for it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pirate_bt.errors import ConfigurationError
from pirate_bt.trace.reader import Trace

__all__ = ["PlotSeries", "StepSpan", "plot_series", "plot_trace"]

_PANELS = (
    ("joint_angle_rad.", "joint angle (deg)", 180.0 / math.pi),
    ("clamp_force_n.", "clamp force (N)", 1.0),
    ("speed", "speed (mm/s)", 1000.0),
    ("rotation_rad", "rotation (deg)", 180.0 / math.pi),
)
_STEP_COLOURS = ("#dbeafe", "#dcfce7", "#fef3c7", "#fce7f3", "#e0e7ff", "#ccfbf1")


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
        t_s: Time of each sample (one per recorded tick).
        values: Series by flat state name (``joint_angle_rad.bend_1``), plus
            ``speed`` (mean drive speed in m/s); ``nan`` before a value is known.
        steps: The active PAB steps over time.
    """

    t_s: list[float] = field(default_factory=list)
    values: dict[str, list[float]] = field(default_factory=dict)
    steps: list[StepSpan] = field(default_factory=list)


def _as_float(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def plot_series(trace: Trace) -> PlotSeries:
    """Collect the series a plot needs from ``trace`` (no matplotlib needed)."""
    series = PlotSeries()
    steps = trace.structure.steps()
    active: tuple[str, str, float] | None = None
    for frame in trace.frames():
        if frame.n == 0:
            continue
        series.t_s.append(frame.t_s)
        index = len(series.t_s) - 1
        speeds: list[float] = []
        for key, value in frame.state.items():
            number = _as_float(value)
            if key.startswith("drive_velocity_mps."):
                speeds.append(number)
            column = series.values.setdefault(key, [math.nan] * index)
            column.append(number)
        speed_column = series.values.setdefault("speed", [math.nan] * index)
        speed_column.append(sum(speeds) / len(speeds) if speeds else math.nan)
        for column in series.values.values():
            if len(column) < index + 1:
                column.append(column[-1] if column else math.nan)
        running = next((s for s in steps if frame.status.get(s.id) == "R"), None)
        if active is not None and (running is None or running.id != active[0]):
            series.steps.append(StepSpan(active[0], active[1], active[2], frame.t_s))
            active = None
        if running is not None and active is None:
            active = (running.id, running.name, frame.t_s)
    if active is not None:
        series.steps.append(StepSpan(active[0], active[1], active[2], trace.duration_s))
    return series


def _shade(axes: Iterable[Any], steps: list[StepSpan]) -> None:
    colours: dict[str, str] = {}
    for span in steps:
        colour = colours.setdefault(span.node, _STEP_COLOURS[len(colours) % len(_STEP_COLOURS)])
        for ax in axes:
            ax.axvspan(span.start_s, max(span.end_s, span.start_s + 1e-6), color=colour, lw=0)


def plot_trace(trace: Trace, out: str | Path, title: str | None = None) -> Path:
    """Draw the joints, clamps, speed and rotation of a run to a PNG (or SVG/PDF) file.

    Args:
        trace: The trace, from :func:`~pirate_bt.trace.reader.read_trace`.
        out: The picture's path; the format follows the suffix (``.png`` usually).
        title: A title; defaults to the tree's name and outcome.

    Returns:
        ``out`` as a path.

    Raises:
        ConfigurationError: matplotlib is not installed.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ConfigurationError(
            "plotting needs matplotlib: pip install 'pirate-bt[plot]'"
        ) from None
    series = plot_series(trace)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(len(_PANELS), 1, sharex=True, figsize=(10, 8.5), dpi=100)
    try:
        _shade(axes, series.steps)
        for ax, (prefix, label, scale) in zip(axes, _PANELS, strict=True):
            keys = sorted(
                k
                for k in series.values
                if k == prefix or (prefix.endswith(".") and k.startswith(prefix))
            )
            for key in keys:
                ys = [v * scale for v in series.values[key]]
                ax.plot(series.t_s, ys, lw=1.2, label=key.partition(".")[2] or key)
            if not keys:
                ax.text(0.5, 0.5, "not recorded", transform=ax.transAxes, ha="center", color="0.5")
            elif len(keys) > 1:
                ax.legend(loc="upper right", fontsize=7, ncols=min(4, len(keys)))
            ax.set_ylabel(label, fontsize=9)
            ax.grid(True, alpha=0.3)
        top = axes[0]
        for span in series.steps:
            top.annotate(
                span.name,
                xy=((span.start_s + span.end_s) / 2, 1.0),
                xycoords=("data", "axes fraction"),
                ha="center",
                va="bottom",
                fontsize=7,
                rotation=20,
            )
        axes[-1].set_xlabel("time (s)")
        fig.suptitle(title or f"{trace.structure.name}: {trace.outcome}", y=0.995)
        fig.tight_layout()
        fig.savefig(out)
    finally:
        plt.close(fig)
    return out

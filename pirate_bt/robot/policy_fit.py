"""Policy values of a robot description that validate as numbers but cannot work.

Each field has its own bounds (:mod:`pirate_bt.robot.configs`), but some values inside
them mean nothing to the robot or switch a protection off without a word: a pipe's
slope is at most 90°, so a ``max_unclamped_slope`` of 90° or more lets both halves go
in a vertical pipe; a bend plane is aligned at its roll or half a turn from it, so an
``alignment_tolerance`` of 90° or more counts every roll as aligned; a sensor whose
readings stay fresh for longer than the host waits on a silent link is trusted when its
board has stopped answering; a motor damaged by over-torque before the stalled-joint
watch can see it stalled (:data:`JOINT_STALL_S`); a rate window longer than the host
trusts a silent link, over which one command's step may be taken.
:func:`policy_problems` finds those, each at its key, with the range accepted;
:mod:`pirate_bt.robot.fitness` asks it with its other rules.
"""

from __future__ import annotations

import math
from typing import Final

from pirate_bt.robot.workable import KeyPath, Workable

__all__ = ["JOINT_STALL_S", "policy_problems"]

JOINT_STALL_S: Final = 0.1
"""How long (clock time) a joint may stay still short of its position setpoint before
the protective layer's stalled-joint watch (:mod:`pirate_bt.safety.supervisor_stall`)
counts it as stalled: two ticks at 20 Hz, well inside the 0.3 s a saturated motor
takes to be damaged (``motion.over_torque_time`` of the bundled robot). Here, below
the safety layer, so the robot description can be held to it."""


def policy_problems(desc: Workable) -> list[tuple[KeyPath, str]]:
    """The policy values that cannot work, each as ``(path, message)``."""
    return [
        *_angles(desc),
        *_forces(desc),
        *_freshness_limit(desc),
        *_over_torque(desc),
        *_rate_window(desc),
    ]


def _over_torque(desc: Workable) -> list[tuple[KeyPath, str]]:
    """A stalled joint is let go after :data:`JOINT_STALL_S`: a motor damaged sooner
    is damaged before the watch can act."""
    over = desc.motion.over_torque_time
    if over > JOINT_STALL_S + 1e-12:
        return []
    return [
        (
            ("motion", "over_torque_time"),
            f"over_torque_time {_time(over)} is not longer than the {_time(JOINT_STALL_S)}"
            " the stalled-joint watch waits before it lets a stalled joint go: a stalled"
            f" motor would be damaged before it is seen; give a time above {_time(JOINT_STALL_S)}",
        )
    ]


def _rate_window(desc: Workable) -> list[tuple[KeyPath, str]]:
    """``safety.rate_window`` is the longest time one command's rate-limited step is
    taken over (after a pause, or from the measured value when there is no last
    setpoint). The host trusts what it knows of the robot for ``safety.max_link_silence``
    at most; a longer window lets one command step a joint or a drive as far as its
    limit allows over that longer time (a million seconds: any step at all), a rate
    limit that holds nothing after a pause."""
    window, silence = desc.safety.rate_window, desc.safety.max_link_silence
    if window <= silence * (1 + 1e-9):
        return []
    return [
        (
            ("safety", "rate_window"),
            f"rate_window {_time(window)} is longer than safety.max_link_silence"
            f" {_time(silence)}: one command after a pause could step a joint or a drive"
            f" as far as its rate limit allows over {_time(window)}, a limit that holds"
            f" nothing; give a window above 0 s and at most {_time(silence)}",
        )
    ]


def _deg(rad: float) -> str:
    return f"{math.degrees(rad):.4g}"


def _time(seconds: float) -> str:
    return f"{seconds:.4g} s" if seconds >= 1 else f"{seconds * 1000:.4g} ms"


def _angles(desc: Workable) -> list[tuple[KeyPath, str]]:
    out: list[tuple[KeyPath, str]] = []
    slope = desc.motion.max_unclamped_slope
    if slope >= math.pi / 2 - 1e-12:
        out.append(
            (
                ("motion", "max_unclamped_slope"),
                f"max_unclamped_slope {_deg(slope)} deg is no slope a pipe has: a pipe"
                " rises at most 90 deg, so both halves could let go in a vertical pipe"
                " and the robot fall; give an angle from 0 deg up to, not including,"
                " 90 deg",
            )
        )
    align = desc.motion.alignment_tolerance
    if align >= math.pi / 2 - 1e-12:
        out.append(
            (
                ("motion", "alignment_tolerance"),
                f"alignment_tolerance {_deg(align)} deg counts every roll as aligned with a"
                " bend: a bend plane is aligned at its roll or half a turn from it, so"
                " no roll is more than 90 deg from both; give an angle above 0 deg and"
                " below 90 deg",
            )
        )
    return out


def _forces(desc: Workable) -> list[tuple[KeyPath, str]]:
    safety = desc.safety
    release, clamp = safety.release_force_fraction, safety.clamp_force_fraction
    if release == 0.0:
        return [
            (
                ("safety", "release_force_fraction"),
                "release_force_fraction 0 counts no half as free (its spring force is"
                " never below 0): no release could be confirmed; give a fraction above 0"
                f" and below clamp_force_fraction {clamp:g}",
            )
        ]
    if release >= clamp:
        return [
            (
                ("safety", "release_force_fraction"),
                f"release_force_fraction {release:g} is not below clamp_force_fraction"
                f" {clamp:g}: a clamp step would count as done at a spring force that still"
                " reads as a free half; give a fraction above 0 and below"
                f" {clamp:g}",
            )
        ]
    return []


def _freshness_limit(desc: Workable) -> list[tuple[KeyPath, str]]:
    """A reading counts as fresh for ``safety.stale_after_periods`` x its sensor's
    period: no longer than ``safety.max_link_silence``, the longest the host trusts a
    silent link, or the protective layer acts on a board's last readings long after
    that board stopped answering. The slowest sensor is named, at its period."""
    factor = desc.safety.stale_after_periods
    silence = desc.safety.max_link_silence
    worst: tuple[float, KeyPath, str] | None = None
    for b, board in enumerate(desc.boards):
        for s, sensor in enumerate(board.sensors):
            limit = factor * sensor.period
            if limit > silence * (1 + 1e-9) and (worst is None or limit > worst[0]):
                worst = (limit, ("boards", b, "sensors", s, "period"), sensor.name)
    if worst is None:
        return []
    limit, path, name = worst
    slowest = limit / factor
    most = silence / slowest  # stale_after_periods must stay above 1
    fewer = f", or a stale_after_periods of at most {most:.4g}" if most > 1 else ""
    return [
        (
            path,
            f"the readings of sensor {name!r} would count as fresh for {_time(limit)}"
            f" (safety.stale_after_periods {factor:g} x its period {_time(slowest)}),"
            f" longer than safety.max_link_silence {_time(silence)}: the protective layer"
            " would act on a board's last readings long after it stopped answering; give"
            f" a period of at most {_time(silence / factor)}{fewer}",
        )
    ]

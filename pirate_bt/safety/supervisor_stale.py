"""Why the supervisor's safety readings went stale, for its safe state's cause.

Split out of :mod:`pirate_bt.safety.supervisor` (its tick found the stale readings and
said why in place). Two causes: no ``STATE`` came since the readings were fresh (the
link fell silent, or its STATE frames were refused: a link error, exit 3), or one came
without them (a board the bridge reports not answering, a sensor dropout).
"""

from __future__ import annotations

from pirate_bt.errors import LinkError
from pirate_bt.link.away import stale_because_away
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.port import RobotPort
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.verdict import Reason

__all__ = ["stale_cause"]


def stale_cause(
    robot: RobotDescription,
    port: RobotPort,
    state: RobotState,
    stale: list[tuple[str, float]],
    now: float,
) -> tuple[str, LinkError | None]:
    """The safe state's cause for the ``stale`` readings (name, age) of ``state``, the
    newest snapshot, and the error behind it (a :class:`~pirate_bt.errors.LinkError`
    when the link is the cause, else ``None``)."""
    names = ", ".join(f"{n} ({a:.3f} s)" for n, a in stale[:4])
    no_state = now - state.stamp_s
    if no_state >= min(age for _, age in stale) - 1e-9:
        # no STATE frame came since these readings were fresh: they went stale because
        # the link fell silent, which is the first cause (a link error, exit 3), found
        # before max_link_silence runs out. Its newest STATE, not its newest frame: an
        # ACK heard after the last STATE (then nothing) made the same silence "stale
        # data", exit 1.
        health = port.health()
        silent = health.silent_for(now)
        heard = (
            health.silence_text(silent)
            if silent >= no_state - 1e-9
            else f"no state frame from the bridge for {no_state:.3f} s (the"
            f" last frame heard, {silent:.3f} s ago, held no state)"
        )
        if refused := health.states_refused_text():  # not silent: refused
            heard = f"no state frame taken for {no_state:.3f} s: {refused}"
        if silent < no_state - 1e-9:
            # good frames came since the last STATE (ACKs, heartbeats), so the line's
            # noise since the last good frame says nothing of the STATEs: name what
            # came unreadable since the last STATE (garbled STATEs, likely), so that a
            # noisy line is not taken for a bridge that stopped sending its state
            noise: str = getattr(port, "noise_since_state", str)()
            if noise:
                heard = f"{heard}; {noise} came since the last STATE taken"
        cause = f"{Reason.LINK_SILENT}: {heard}, so its readings are stale: {names}"
        return cause, LinkError(cause)
    # a board the bridge reports in TIMEOUT (rebooting) is the cause
    away: tuple[int, ...] = getattr(port, "boards_not_answering", tuple)()
    why = stale_because_away(robot, away, stale)
    return f"stale data: {names}{why}", None

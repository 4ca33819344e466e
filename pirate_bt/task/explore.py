"""The ``explore`` navigator: survey a pipe with no map, and write what it found.

It drives on until something stops it, finds out what that was, and goes on:

1. ``Step("straight", distance=search, stop_at_feature=True)``, again and again;
2. stopped *blocked*: ``Step("probe-turn")`` (trees/probe-turn.yaml) tries each roll
   with the steered front half: a bend that way, or the end of the pipe;
3. a bend: ``Step("bend", direction=...)`` through it, then on (1);
4. the end: the survey is done; it is written as a network file (the format of
   ``scenarios/*.yaml``) that plans and runs routes as a drawing does.

Lengths come from the odometry, on the pipe's centre line: a straight runs from the
end of the feature before it to where the robot was blocked (the front tip stops at
a bend's start, or at the pipe's end), a bend's arc is ``radius x 90 deg``. The
diameter comes from the rear half's wall-contact angles and the slope from the IMU,
where each straight ends.

Not yet (a survey that meets one stops safe, with the cause named and what was
surveyed so far written): T-joints (an opening felt: which side its branch leaves
on needs a probe of its own, and the robot backing out of a branch), reducers inside
a straight, bends met on a vertical run, bends other than 90 degrees in the four
cardinal rolls.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

from pirate_bt.errors import InputError
from pirate_bt.task.navigation import Felt, Observation, Step
from pirate_bt.units import parse_quantity

__all__ = ["ExploreNavigator", "SurveyIncomplete"]

_TURN = {"up": 90.0, "down": -90.0}
"""The slope change of a bend up or down (left and right keep it)."""


class SurveyIncomplete(RuntimeError):
    """The survey met what it cannot survey yet; what it surveyed is written."""


def _metres(value: str | float, what: str, dimension: str = "length") -> float:
    number = float(value) if isinstance(value, int | float) else parse_quantity(value, dimension)
    if not math.isfinite(number) or number <= 0:
        raise InputError(f"explore: {what} must be positive, not {value!r}")
    return number


class ExploreNavigator:
    """Survey a network with no map: straights, bends and the end of the pipe.

    Args:
        output: Where to write the surveyed network (a ``.yaml`` file); ``None``:
            only :attr:`network` holds it.
        search: How far one straight step drives before it looks again.
        radius: The bends' centre-line radius (the robot does not measure it yet).
        name: The surveyed network's name.
    """

    def __init__(
        self,
        output: str | Path | None = None,
        search: str | float = "3 m",
        radius: str | float = "90 mm",
        name: str = "surveyed",
    ) -> None:
        self.output = Path(output) if output is not None else None
        self.search_m = _metres(search, "search")
        self.radius_m = _metres(radius, "radius")
        if not name or any(c in name for c in "\n\r"):
            raise InputError(f"explore: a network name is one line of text, not {name!r}")
        self.name = name
        self.segments: list[dict[str, Any]] = []
        """The segments found so far, as a network file writes them."""
        self.network: Any = None
        """The surveyed :class:`~pirate_bt.pipes.NetworkSpec`, once written."""
        self._from_m: float | None = None  # belief where the current straight began
        self._blocked_m: float | None = None
        self._diameter_m: float | None = None
        self._slope_deg = 0.0  # the slope the pipe carries into the current straight
        self._driven_in_straight = 0

    # -- the loop

    def next_step(self, obs: Observation) -> Step | None:
        if obs.map is not None:
            raise InputError("explore surveys a pipe with no map: run it without map=")
        if obs.last is not None and obs.last.outcome != "success":
            self._write(obs, f"stopped: {obs.last.why}")
            return None  # the navigation's result names the failed step's cause
        if self._from_m is None:  # the start: the rear tip at the pipe's entry
            self._from_m = obs.belief.position_m - obs.robot_length_m
        felt = obs.felt[-1] if obs.felt else None
        pab = obs.history[-1][0].pab if obs.history else None
        if pab == "probe-turn":
            return self._probed(obs, felt)
        if pab == "straight" and felt is not None and felt.kind == "feature":
            if felt.how == "opening":
                self._close_straight(obs, felt.at_m)
                self._write(obs, f"stopped at an opening at {felt.at_m:.2f} m (a T-joint?)")
                raise SurveyIncomplete(
                    f"an opening (a T-joint?) at {felt.at_m:.2f} m: explore does not survey"
                    " T-joints yet; the survey so far is written"
                    + (f" to {self.output}" if self.output else "")
                )
            self._blocked_m = felt.at_m
            return Step("probe-turn")
        return Step("straight", distance=self.search_m, stop_at_feature=True)

    def _probed(self, obs: Observation, felt: Felt | None) -> Step | None:
        assert self._blocked_m is not None
        if felt is None:
            raise SurveyIncomplete(
                "probe-turn ended without an answer (neither a turn nor the end)"
            )
        self._close_straight(obs, self._blocked_m)
        if felt.kind == "end":
            self._write(obs, None)
            return None
        direction = str(felt.direction)
        self.segments.append(
            {"id": f"bend-{self._count('bend') + 1}", "type": "bend", "direction": direction}
        )
        if self.radius_m != 0.09:
            self.segments[-1]["radius"] = f"{self.radius_m * 1000:.1f} mm"
        self._from_m = self._blocked_m + self.radius_m * math.pi / 2
        self._slope_deg = max(-90.0, min(90.0, self._slope_deg + _TURN.get(direction, 0.0)))
        return Step("bend", direction=direction)

    # -- what was found

    def _count(self, kind: str) -> int:
        return sum(1 for s in self.segments if s["type"] == kind)

    def _close_straight(self, obs: Observation, end_m: float) -> None:
        assert self._from_m is not None
        length = end_m - self._from_m
        if length < 0.005:  # a bend right after a bend: no straight between
            return
        segment: dict[str, Any] = {
            "id": f"run-{self._count('straight') + 1}",
            "type": "straight",
            "length": f"{length:.3f} m",
        }
        # read where the straight ends, the rear half holding in it; the first one
        # read is the network's, a straight that differs by over 2 mm says so
        if obs.diameter_m is not None and self._diameter_m is None:
            self._diameter_m = obs.diameter_m
        elif obs.diameter_m is not None and abs(obs.diameter_m - (self._diameter_m or 0)) > 0.002:
            segment["diameter"] = f"{obs.diameter_m * 1000:.1f} mm"
        if obs.pitch_rad is not None:
            pitch = math.degrees(obs.pitch_rad)
            if abs(pitch - self._slope_deg) > 1.0:  # sloped otherwise than carried in
                segment["slope"] = f"{pitch:.1f} deg"
                self._slope_deg = pitch
        self.segments.append(segment)

    def _write(self, obs: Observation, stopped: str | None) -> None:
        """Build the network of what was surveyed, and write it if asked to."""
        from pirate_bt.pipes.asbuilt import network_yaml
        from pirate_bt.pipes.model import NetworkSpec

        if not any(s["type"] == "straight" for s in self.segments):
            return  # nothing surveyed: no network to write
        diameter = self._diameter_m
        about = "Surveyed by pirate_bt's explore navigator"
        about += f"; {stopped}" if stopped else " to the end of the pipe"
        data: dict[str, Any] = {
            "schema_version": 1,
            "name": self.name,
            "description": about + ".",
            "diameter": f"{(diameter or 0.063) * 1000:.1f} mm",
            "segments": self.segments,
        }
        self.network = NetworkSpec.model_validate(data)
        if self.output is None:
            return
        header = (
            f"{about}.\nLengths from odometry on the centre line (within about 5 % of"
            f" each length);\nbend radius assumed {self.radius_m * 1000:g} mm;"
            " diameters from the clamp angles, slopes from the IMU."
        )
        text = network_yaml(self.network, header=header)
        self.output.parent.mkdir(parents=True, exist_ok=True)
        part = self.output.with_name(self.output.name + ".part")
        part.write_text(text, encoding="utf-8")
        os.replace(part, self.output)  # never half a file

"""The plan as one tree: subtree references to the PAB trees, guarded by ``map_ok``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pirate_bt.errors import ConfigurationError
from pirate_bt.task.plan import LEG_DISTANCE_KEY, MAP_OK_KEY, PAB_FILES, MissionPlan

__all__ = ["STEER_MARGIN_RAD", "mission_tree_spec", "steer_param"]

STEER_MARGIN_RAD = math.radians(10.0)
"""How far past the robot's ``motion.steer_angle`` a PAB steers a half when its tree's
own ``steer`` default is too little for the robot (the bundled trees steer 40°, the
reference robot counts 30° as steered)."""


def _pab_file(trees_dir: Path, pab: str) -> Path:
    path = trees_dir / PAB_FILES[pab]
    if not path.is_file():
        raise ConfigurationError(
            f"the PAB tree {path} is missing; the mission needs {', '.join(PAB_FILES.values())}"
        )
    return path


def _declared_params(path: Path) -> dict[str, float | None]:
    """The parameters a PAB tree declares, each with its default in SI units where it
    is a velocity, an angle or a torque with a default (``None`` otherwise)."""
    from pirate_bt.errors import UnitError
    from pirate_bt.units import parse_quantity
    from pirate_bt.yamlfile import load_yaml

    data = load_yaml(path).data
    params = data.get("params") if isinstance(data, dict) else None
    if not isinstance(params, dict):
        return {}
    declared: dict[str, float | None] = {}
    for name, spec in params.items():
        default = None
        kind = spec.get("type") if isinstance(spec, dict) else None
        if kind in ("velocity", "angle", "torque") and "default" in spec:
            try:
                default = parse_quantity(spec["default"], str(kind))
            except UnitError:
                default = None  # the tree's own check says what is wrong with it
        declared[str(name)] = default
    return declared


def pab_torque_nm(trees_dir: Path | None = None) -> float | None:
    """The clamp torque the bend PAB presses with when a mission gives none (its
    ``torque`` parameter's default), or ``None`` where its tree declares none."""
    from pirate_bt.resources import data_dir

    path = (trees_dir or data_dir("trees")) / PAB_FILES["bend"]
    return _declared_params(path).get("torque") if path.is_file() else None


def steer_param(path: Path, steer_angle_rad: float) -> dict[str, float]:
    """``{"steer": angle}`` for the PAB tree at ``path`` when it declares a ``steer``
    parameter whose default is too little for a robot that counts ``steer_angle_rad``
    (its ``motion.steer_angle``) as steered: the robot's angle and
    :data:`STEER_MARGIN_RAD`. Empty where the default is enough (within half the
    margin of it or more), so a run with the reference robot is as before."""
    return _steer_for(_declared_params(path), steer_angle_rad)


def _steer_for(declared: dict[str, float | None], steer_angle_rad: float) -> dict[str, float]:
    """:func:`steer_param` of a tree's declared parameters (read once per PAB kind)."""
    if "steer" not in declared:
        return {}
    default = declared["steer"]
    if default is not None and default >= steer_angle_rad + STEER_MARGIN_RAD / 2:
        return {}
    return {"steer": steer_angle_rad + STEER_MARGIN_RAD}


def mission_tree_spec(
    plan: MissionPlan,
    trees_dir: Path | None = None,
    nominal_speed_mps: float | None = None,
    steer_angle_rad: float | None = None,
) -> dict[str, Any]:
    """The plan as one tree, in the mapping form of :func:`pirate_bt.treefile.load_tree`.

    The root is an ``eternal_guard`` on ``map_ok`` around a sequence of subtree
    references, one per PAB, named ``NN what (line L)``.

    Args:
        plan: The mission plan.
        trees_dir: Where the PAB trees are (default: the bundled ``trees/``).
        nominal_speed_mps: The robot's cruise speed; with it, slow straights pass
            ``speed`` when the straight PAB declares that parameter.
        steer_angle_rad: The robot's ``motion.steer_angle``; with it, a PAB whose tree
            declares ``steer`` with a default too little for the robot is passed
            enough (:func:`steer_param`).

    Raises:
        ConfigurationError: a PAB tree file is missing.
    """
    from pirate_bt.resources import data_dir

    folder = trees_dir or data_dir("trees")
    declared: dict[str, dict[str, float | None]] = {}
    children: list[dict[str, Any]] = []
    for index, pab in enumerate(plan.pabs, start=1):
        name = pab.label(index)
        if pab.pab == "pause":
            children.append({"type": "wait", "name": name, "duration": pab.params["duration"]})
            continue
        path = _pab_file(folder, pab.pab)
        if pab.pab not in declared:
            declared[pab.pab] = _declared_params(path)
        params = {k: v for k, v in pab.params.items() if k != "slow"}
        speed = nominal_speed_mps
        if pab.params.get("slow") and nominal_speed_mps is not None:
            speed = nominal_speed_mps * plan.contract.slow_factor
        if params.get("distance", 0.0) < 0:
            # Backwards: the straight PAB drives a positive distance at a negative velocity.
            params["distance"] = -params["distance"]
            speed = -(speed or 0.08)
        if pab.pab == "straight" and "distance_key" in declared[pab.pab]:
            # the mission writes the leg's distance from its belief when the leg starts
            params["distance_key"] = LEG_DISTANCE_KEY
            if pab.end_m > pab.start_m and "stop_at_feature" in declared[pab.pab]:
                params["stop_at_feature"] = True
        if speed is not None:
            for key in ("speed", "velocity"):
                # only where it differs from the tree's own default: a robot whose
                # cruise speed is another (a slower drive) drives its legs at it
                if key in declared[pab.pab] and declared[pab.pab][key] != speed:
                    params[key] = speed
        if steer_angle_rad is not None:
            params.update(_steer_for(declared[pab.pab], steer_angle_rad))
        node: dict[str, Any] = {
            "type": "subtree",
            "name": name,
            "ref": str(path.resolve()),
            "params": params,
        }
        if pab.inspect:
            node = {
                "type": "sequence",
                "name": name,
                "children": [
                    {
                        "type": "log",
                        "name": "inspect",
                        "message": f"inspecting {pab.start_m:.2f}-{pab.end_m:.2f} m",
                    },
                    {**node, "name": "drive"},
                ],
            }
        children.append(node)
    return {
        "name": f"mission {plan.route.name}",
        "description": f"route {plan.route.source} in network {plan.network.name}",
        "blackboard": {MAP_OK_KEY: {"type": "boolean", "default": True, "external": True}},
        "root": {
            "type": "eternal_guard",
            "name": "mission",
            "conditions": [
                {
                    "type": "check_blackboard",
                    "name": "belief fits the map",
                    "key": MAP_OK_KEY,
                    "op": "==",
                    "value": True,
                }
            ],
            "child": {"type": "sequence", "name": "route", "children": children},
        },
    }

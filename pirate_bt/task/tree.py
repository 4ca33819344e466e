"""The plan as one tree: subtree references to the PAB trees, guarded by ``map_ok``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pirate_bt.errors import ConfigurationError
from pirate_bt.task.plan import LEG_DISTANCE_KEY, MAP_OK_KEY, PAB_FILES, MissionPlan

__all__ = ["mission_tree_spec"]


def _pab_file(trees_dir: Path, pab: str) -> Path:
    path = trees_dir / PAB_FILES[pab]
    if not path.is_file():
        raise ConfigurationError(
            f"the PAB tree {path} is missing; the mission needs {', '.join(PAB_FILES.values())}"
        )
    return path


def _declared_params(path: Path) -> dict[str, float | None]:
    """The parameters a PAB tree declares, each with its default speed in m/s where it
    is a velocity with a default (``None`` otherwise)."""
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
        if isinstance(spec, dict) and spec.get("type") == "velocity" and "default" in spec:
            try:
                default = parse_quantity(spec["default"], "velocity")
            except UnitError:
                default = None  # the tree's own check says what is wrong with it
        declared[str(name)] = default
    return declared


def mission_tree_spec(
    plan: MissionPlan,
    trees_dir: Path | None = None,
    nominal_speed_mps: float | None = None,
) -> dict[str, Any]:
    """The plan as one tree, in the mapping form of :func:`pirate_bt.treefile.load_tree`.

    The root is an ``eternal_guard`` on ``map_ok`` around a sequence of subtree
    references, one per PAB, named ``NN what (line L)``.

    Args:
        plan: The mission plan.
        trees_dir: Where the PAB trees are (default: the bundled ``trees/``).
        nominal_speed_mps: The robot's cruise speed; with it, slow straights pass
            ``speed`` when the straight PAB declares that parameter.

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

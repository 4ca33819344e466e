"""Probe 8 (hostile trees), with the behaviours patch: a comparison's value is finite.

``check_blackboard``, ``set_blackboard`` and the guards' comparisons took ``.nan`` and
``.inf``: every comparison with NaN is false, so ``op: '!='`` always held (a skip_if
always skipped)."""

from __future__ import annotations

import pytest

from pirate_bt.errors import ValidationFailed
from pirate_bt.treefile import load_tree


@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
@pytest.mark.parametrize(
    "root",
    [
        {"type": "check_blackboard", "key": "x", "op": "!=", "value": None},
        {"type": "set_blackboard", "key": "x", "value": None},
        {
            "type": "skip_if",
            "condition": {"blackboard": "x", "op": "!=", "value": None},
            "child": "success",
        },
    ],
)
def test_a_non_finite_comparison_value_is_refused(root: dict[str, object], value: float) -> None:
    node = dict(root)
    if "condition" in node:
        node["condition"] = {**node["condition"], "value": value}  # type: ignore[dict-item]
    else:
        node["value"] = value
    with pytest.raises(ValidationFailed, match="finite number"):
        load_tree({"blackboard": {"x": {"default": 1}}, "root": node})

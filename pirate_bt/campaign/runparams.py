"""A tree run's parameters as its tree will read them, for telling runs apart.

Two runs of one tree whose parameters differ only where one leaves a parameter to
its default and the other names that default (``{distance: 1 m}`` and ``{distance:
1 m, torque: 0.7 N*m}`` for a ``torque`` declared with ``default: 0.7 N*m``) run
the same cases: :func:`params_as_read` gives both the same parameters, the defaults
filled in, so the spec's check of repeated axis entries
(:func:`pirate_bt.campaign.checks.check_axes`) refuses the second. They were taken
as two points, and their identical, deterministic cases counted as independent
samples.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from pirate_bt.campaign.inputs import resolve_name

__all__ = ["params_as_read"]


def params_as_read(
    run: Any, folder: Path, load: Callable[[str, Mapping[str, str]], Any] | None = None
) -> Mapping[str, Any]:
    """``run.params`` with the tree's declared defaults filled in, each as the tree
    reads it; a navigator run's with the defaults of its signature filled in (``explore``'s
    ``search: 3 m``); ``run.params`` as written for a route run, or when the tree does
    not load with them (its own check then says why).

    ``load(tree, params)`` loads the tree with its parameters (texts) and no robot,
    ``None`` when it does not load: a check's :meth:`~pirate_bt.campaign.loads.Loads.
    tree`, which loads each once for all the checks of a spec (default: a load of its
    own).
    """
    if run.navigator is not None:  # its defaults as its signature gives them
        from pirate_bt.task.navigators import navigator_defaults

        return {**navigator_defaults(run.navigator), **run.params}
    tree = resolve_name(run.tree, folder)
    if tree is None:
        return dict(run.params)
    if load is None:
        from pirate_bt.campaign.loads import Loads

        load = Loads().tree
    # as a case passes them on: `true`, not `True` (cases.param_text)
    params = {k: str(v).lower() if isinstance(v, bool) else str(v) for k, v in run.params.items()}
    loaded = load(tree, params)
    return dict(run.params) if loaded is None else dict(loaded.params)

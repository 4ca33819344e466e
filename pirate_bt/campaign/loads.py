"""What one check of a campaign spec loads, each once.

A spec of 10 runs over 100 robot files is 1,000 cases, and each case's tree must load
with its parameters against its robot, as the case will (:func:`~pirate_bt.campaign.
checks.check_runs`). Loading it 1,000 times (and each robot file twice, once to
validate it and once to load it) took 36 s of ``pirate-bt validate``. A :class:`Loads`
lives for one check of one spec (no cache outlives it: a file edited between two
checks is read again): each robot file is loaded once, each distinct tree with its
parameters once, without a robot, and a robot's part of the check, its limits, is
asked of each node of that one load (:meth:`Loads.fits`). Only a case whose robot
refuses it is loaded again against its robot, to say why in the loader's words.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.treefile.spec import LoadedTree

__all__ = ["Loads"]


class Loads:
    """Robot descriptions and trees loaded for one check of a spec, once each."""

    def __init__(self) -> None:
        self._robots: dict[str | None, RobotDescription] = {}
        self._trees: dict[tuple[str, str], LoadedTree | None] = {}
        self._fits: dict[tuple[int, int], bool] = {}

    def robot(self, name: str | None) -> RobotDescription:
        """The robot description file ``name`` (``None``: the bundled one), loaded once.

        Raises:
            ValidationFailed: it does not validate (not kept: asked again, it is read
                again and says so again).
        """
        if name not in self._robots:
            from pirate_bt.robot.loader import load_robot

            self._robots[name] = load_robot(name) if name is not None else load_robot()
        return self._robots[name]

    __call__ = robot  # what the navigator checks ask for a case's robot

    def keep_robot(self, name: str | None, robot: RobotDescription) -> None:
        """``robot`` is the file ``name`` as loaded (and validated) elsewhere."""
        self._robots.setdefault(name, robot)

    def tree(self, tree: str, params: Mapping[str, str]) -> LoadedTree | None:
        """The tree file or bundled name ``tree`` loaded with ``params`` (texts, as a
        case passes them) and no robot's limits (a BehaviorTree.CPP XML file: the
        bundled robot's, as its reader checks it), once per distinct pair; ``None``
        when it does not load so (whoever needs the reason loads it again)."""
        from pirate_bt.api.running import load_tree_source
        from pirate_bt.resources import find_file

        try:
            source = find_file("trees", tree)
            name = str(source.resolve())
        except Exception:  # a name the system refuses: said by the check of the file
            return None
        key = (name, json.dumps(dict(params), sort_keys=True))
        if key not in self._trees:
            try:
                self._trees[key] = load_tree_source(
                    source,
                    robot=None,
                    params=params,
                    params_from_text=True,
                    params_origin="--param",
                )
            except Exception:  # its problems are said where the reason is needed
                self._trees[key] = None
        return self._trees[key]

    def fits(self, loaded: LoadedTree, robot: RobotDescription) -> bool:
        """Whether every node of ``loaded`` is within ``robot``'s limits: the one check
        a tree's load makes of its robot (each node's ``check_limits``, in the reader
        and again as it is built), so ``True`` is a load against ``robot`` that
        succeeds."""
        key = (id(loaded), id(robot))  # both kept alive by this object
        if key not in self._fits:
            self._fits[key] = not any(
                node.cls.check_limits(node.params, robot)
                for node in loaded.spec.walk()
                if node.cls is not None and node.params is not None
            )
        return self._fits[key]

"""A run's coverage as data: per node, what it did; merged over runs; as JSON and a table.

:class:`Coverage` holds a :class:`NodeCoverage` per node of a tree, depth first:
the counts :class:`~pirate_bt.trace.coverage.CoverageRecorder` made in a run (or
:func:`merge_coverage` added up over many), which nodes never ran
(:meth:`Coverage.never_ran`), which guards never failed
(:meth:`Coverage.never_failed`), and a compact JSON form
(:meth:`Coverage.as_dict`, :meth:`Coverage.from_dict`) that campaigns keep per
run. What the counts mean: :mod:`pirate_bt.trace.coverage`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Final

from pirate_bt.errors import shown

__all__ = [
    "GUARDS",
    "Coverage",
    "NodeCoverage",
    "coverage_problem",
    "merge_coverage",
    "name_paths",
]

_FIELDS: Final = ("ticks", "transitions", "successes", "failures", "halts", "skips")
_LETTER: Final = {"composite": "c", "decorator": "d", "guard": "g", "condition": "q", "leaf": "l"}
GUARDS: Final = ("guard", "condition")
"""The kinds whose failure is a branch worth exercising: guards and conditions."""


@dataclass(frozen=True, slots=True)
class NodeCoverage:
    """What one node did in a run (or in many runs, merged).

    Attributes:
        path: The node's names from the root, joined by ``/`` (``bend/pass
            bend/clamp front``); a name repeated among siblings gets ``#ID``.
        id: The node's path id (``0.1.2``), as in traces and diagrams.
        type: The behaviour's class name.
        kind: ``composite``, ``decorator``, ``guard``, ``condition`` (a leaf that only
            answers success or failure, such as ``is_clamped`` or the
            ``check_blackboard`` a guard asks) or ``leaf``.
        ticks: Ticks that reached the node.
        transitions: Status changes to RUNNING, SUCCESS or FAILURE, as BT.CPP's
            ``TreeObserver`` counts them.
        successes: Transitions to SUCCESS.
        failures: Transitions to FAILURE.
        halts: Stops while RUNNING.
        skips: Times its guard answered for it without ticking it.
    """

    path: str
    id: str
    type: str
    kind: str
    ticks: int = 0
    transitions: int = 0
    successes: int = 0
    failures: int = 0
    halts: int = 0
    skips: int = 0

    @property
    def ran(self) -> bool:
        """The node was ticked at least once."""
        return self.ticks > 0

    def counts(self) -> list[int]:
        """``[ticks, transitions, successes, failures, halts, skips]``."""
        return [getattr(self, name) for name in _FIELDS]


@dataclass(frozen=True)
class Coverage:
    """Per node of a tree, what it did in a run: :class:`NodeCoverage` in depth-first order.

    Attributes:
        tree: The tree's name.
        nodes: Every node, depth first (the root first).
        runs: How many runs the counts add up (1 for one run, more once merged).
    """

    tree: str
    nodes: tuple[NodeCoverage, ...]
    runs: int = 1
    _by_path: dict[str, NodeCoverage] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._by_path.update({n.path: n for n in self.nodes})

    def node(self, path: str) -> NodeCoverage:
        """The node at a name path (``KeyError`` if there is none)."""
        return self._by_path[path]

    def __iter__(self) -> Iterator[NodeCoverage]:
        return iter(self.nodes)

    def __len__(self) -> int:
        return len(self.nodes)

    def never_ran(self) -> list[NodeCoverage]:
        """Nodes no tick ever reached."""
        return [n for n in self.nodes if not n.ran]

    def never_failed(self, kinds: Iterable[str] | None = None) -> list[NodeCoverage]:
        """Nodes that ran but never failed (of these kinds, e.g. ``GUARDS``): a guard or
        condition that never failed is a failure branch no run exercised."""
        wanted = None if kinds is None else set(kinds)
        return [
            n
            for n in self.nodes
            if n.ran and not n.failures and (wanted is None or n.kind in wanted)
        ]

    @property
    def ran_fraction(self) -> float:
        """The share of nodes that ran."""
        return sum(n.ran for n in self.nodes) / len(self.nodes) if self.nodes else 0.0

    def summary(self) -> str:
        """One line: how many nodes ran, how many never failed."""
        ran = sum(n.ran for n in self.nodes)
        guards = [n for n in self.nodes if n.kind in GUARDS and n.ran]
        unfailed = [n for n in guards if not n.failures]
        runs = f" over {self.runs} runs" if self.runs != 1 else ""
        text = f"{ran} of {len(self.nodes)} nodes ran ({100 * self.ran_fraction:.0f} %){runs}"
        if guards:
            text += (
                f"; {len(unfailed)} of {len(guards)} guards and conditions that ran never failed"
            )
        return text

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON, compact (a campaign keeps one per run): ``{"tree", "runs", "names",
        "parents", "kinds", "counts"}``: each node's own name and its parent's index (-1
        for the root), depth first; one letter per node for its kind (``c``omposite,
        ``d``ecorator, ``g``uard, ``q`` condition, ``l``eaf); and ``[index, ticks,
        transitions, successes, failures, halts, skips]`` for each node that did anything."""
        by_id = {n.id: i for i, n in enumerate(self.nodes) if n.id}
        by_path = {n.path: i for i, n in enumerate(self.nodes)}
        parents: list[int] = []
        names: list[str] = []
        for n in self.nodes:
            if n.id:
                up = by_id.get(n.id.rpartition(".")[0], -1) if "." in n.id else -1
            else:
                up = by_path.get(n.path.rpartition("/")[0], -1) if "/" in n.path else -1
            prefix = self.nodes[up].path + "/" if up >= 0 else ""
            parents.append(up)
            names.append(n.path[len(prefix) :] if n.path.startswith(prefix) else n.path)
        return {
            "tree": self.tree,
            "runs": self.runs,
            "names": names,
            "parents": parents,
            "kinds": "".join(_LETTER.get(n.kind, "l") for n in self.nodes),
            "counts": [[i, *n.counts()] for i, n in enumerate(self.nodes) if any(n.counts())],
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Coverage:
        """The inverse of :meth:`as_dict` (node types are not kept there: empty).

        Raises:
            ValueError: malformed data.
        """
        names = [str(n) for n in data.get("names") or ()]
        parents = [int(p) for p in data.get("parents") or ()]
        kinds = str(data.get("kinds") or "")
        if len(parents) != len(names) or len(kinds) != len(names):
            raise ValueError("coverage: names, parents and kinds differ in length")
        counts = {int(row[0]): [int(v) for v in row[1:]] for row in data.get("counts") or ()}
        ids: list[str] = []
        seen: dict[int, int] = {}
        for up in parents:
            if up < 0:
                ids.append("0")
            else:
                ids.append(f"{ids[up]}.{seen.get(up, 0)}")
                seen[up] = seen.get(up, 0) + 1
        letters = {letter: kind for kind, letter in _LETTER.items()}
        paths = name_paths(names, parents) if names else []
        nodes = tuple(
            NodeCoverage(
                path, ids[i], "", letters.get(kinds[i], "leaf"), *counts.get(i, [0] * len(_FIELDS))
            )
            for i, path in enumerate(paths)
        )
        return cls(str(data.get("tree", "")), nodes, int(data.get("runs", 1)))

    def by_id(self) -> dict[str, NodeCoverage]:
        """The nodes by path id (for drawing on a tree of the same shape)."""
        return {n.id: n for n in self.nodes if n.id}

    def lines(self) -> list[str]:
        """A table for people: every node with its counts, indented by depth."""
        width = max(
            (len(n.path.rsplit("/", 1)[-1]) + 2 * n.path.count("/") for n in self), default=4
        )
        out = [
            f"{'node':<{width}}  {'ticks':>7} {'trans':>6} {'ok':>5} {'fail':>5}"
            f" {'halts':>5} {'skips':>5}"
        ]
        for n in self.nodes:
            name = "  " * n.path.count("/") + n.path.rsplit("/", 1)[-1]
            out.append(
                f"{name:<{width}}  {n.ticks:>7} {n.transitions:>6} {n.successes:>5}"
                f" {n.failures:>5} {n.halts:>5} {n.skips:>5}"
            )
        return out


def coverage_problem(recorded: object, ids: Iterable[str]) -> str | None:
    """What is wrong with a trace's recorded coverage (the end record's ``coverage``),
    or ``None`` when it is well formed: an object whose ``counts`` map node ids of
    the tree (``ids``) to ``[ticks, transitions, successes, failures, halts, skips]``,
    whole numbers from 0, and whose ``conditions`` list node ids."""
    if not isinstance(recorded, Mapping):
        return f"coverage is {shown(recorded, 40)}, not an object"
    known = set(ids)
    counts = recorded.get("counts")
    if counts is not None and not isinstance(counts, Mapping):
        return f"coverage: counts is {shown(counts, 40)}, not an object"
    for node, row in (counts or {}).items():
        if node not in known:
            return f"coverage: counts: {shown(node, 40)} is no node of the tree"
        if (
            not isinstance(row, list)
            or len(row) != len(_FIELDS)
            or not all(type(v) is int and v >= 0 for v in row)
        ):
            return (
                f"coverage: counts: {node}: {shown(row, 60)} is not {len(_FIELDS)} whole"
                f" numbers from 0 ({', '.join(_FIELDS)})"
            )
    conditions = recorded.get("conditions", [])
    if not isinstance(conditions, list):
        return f"coverage: conditions is {shown(conditions, 40)}, not a list of node ids"
    for node in conditions:
        if not isinstance(node, str) or node not in known:
            return f"coverage: conditions: {shown(node, 40)} is no node of the tree"
    return None


def merge_coverage(many: Iterable[Coverage | Mapping[str, Any]]) -> Coverage | None:
    """Add up the coverage of many runs of one tree, node by node (by name path).

    Runs of different shapes merge too: a node present in some runs only keeps
    the counts of those (and still counts as never ran if no run ticked it).

    Returns:
        The merged coverage, or ``None`` when there is none.
    """
    order: dict[str, list[int]] = {}
    kinds: dict[str, str] = {}
    ids: dict[str, tuple[str, str]] = {}
    tree = ""
    runs = 0
    for item in many:
        cov = Coverage.from_dict(item) if isinstance(item, Mapping) else item
        tree = tree or cov.tree
        runs += cov.runs
        for n in cov.nodes:
            counts = order.setdefault(n.path, [0] * len(_FIELDS))
            for i, value in enumerate(n.counts()):
                counts[i] += value
            kinds.setdefault(n.path, n.kind)
            if n.id:
                ids.setdefault(n.path, (n.id, n.type))
    if not runs:
        return None
    nodes = tuple(
        NodeCoverage(path, *ids.get(path, ("", "")), kinds[path], *counts)
        for path, counts in order.items()
    )
    return Coverage(tree, nodes, runs)


def name_paths(names: Sequence[str], parents: Sequence[int]) -> list[str]:
    """Each node's names from the root; a path that is not unique (siblings sharing a
    name, in trees built in Python) gets ``#INDEX``."""
    paths: list[str] = []
    for index, name in enumerate(names):
        up = parents[index]
        paths.append(name if up < 0 else f"{paths[up]}/{name}")
    counts: dict[str, int] = {}
    for path in paths:
        counts[path] = counts.get(path, 0) + 1
    if all(v == 1 for v in counts.values()):
        return paths
    return [f"{p}#{i}" if counts[p] > 1 else p for i, p in enumerate(paths)]

"""The tree files' sequence and selector, and our leaves and decorators, tick exactly as
py_trees' own do.

:mod:`pirate_bt.behaviours.composites` re-implements ``Sequence.tick`` and
``Selector.tick`` with ``yield from``, and :class:`~pirate_bt.behaviours.base.Leaf` and
:class:`~pirate_bt.behaviours.base.GuardDecorator` ``Behaviour.tick`` and
``Decorator.tick`` in one generator (cost changes only). Random trees of
sequences, selectors (with and without memory), parallels, decorators and scripted
leaves are built twice, once from py_trees' classes and once with ours, and ticked
side by side: every tick must yield the same nodes in the same order, leave every
node with the same status and current child, and call the leaves' ``initialise``,
``update`` and ``terminate`` in the same order.
"""

from __future__ import annotations

import random
from collections.abc import Callable

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.behaviours.base import GuardDecorator, Leaf
from pirate_bt.behaviours.composites import Selector, Sequence
from pirate_bt.safety.verdict import current_issuer
from pirate_bt.treefile import load_tree

STATUSES = (Status.SUCCESS, Status.FAILURE, Status.RUNNING)


class Scripted(py_trees.behaviour.Behaviour):
    """A leaf whose update returns the next status of a seeded script; logs its calls."""

    def __init__(self, name: str, seed: int, log: list[str]) -> None:
        super().__init__(name=name)
        self.rng = random.Random(seed)
        self.log = log

    def initialise(self) -> None:
        self.log.append(f"init {self.name}")

    def update(self) -> Status:
        status = self.rng.choice(STATUSES)
        # py_trees' leaves run as nobody, ours as themselves (pirate_bt.safety.verdict)
        issuer = current_issuer()
        self.log.append(f"update {self.name} {status.name} {issuer is None or issuer is self}")
        return status

    def terminate(self, new_status: Status) -> None:
        self.log.append(f"terminate {self.name} {new_status.name}")


class FastScripted(Scripted):
    """The scripted leaf ticked by :class:`Leaf`'s ``tick()``."""

    tick = Leaf.tick


class FastInverter(py_trees.decorators.Inverter):
    """py_trees' inverter ticked by :class:`GuardDecorator`'s ``tick()``."""

    tick = GuardDecorator.tick


Factory = Callable[[str, bool, list[py_trees.behaviour.Behaviour]], py_trees.behaviour.Behaviour]


def random_tree(
    shape: random.Random, log: list[str], sequence: Factory, selector: Factory, depth: int = 0
) -> py_trees.behaviour.Behaviour:
    """A random tree; ``shape`` is seeded so that both copies get the same shape. Our
    copy (``sequence`` is ours) has our leaves and decorators too."""
    ours = sequence is not _theirs_sequence
    n = shape.getrandbits(32)
    if depth >= 4 or shape.random() < 0.3:
        return (FastScripted if ours else Scripted)(f"leaf{n}", n, log)
    kind = shape.choice(("sequence", "selector", "parallel", "inverter", "sequence", "selector"))
    if kind == "inverter":
        child = random_tree(shape, log, sequence, selector, depth + 1)
        return (FastInverter if ours else py_trees.decorators.Inverter)(f"inv{n}", child)
    children = [
        random_tree(shape, log, sequence, selector, depth + 1) for _ in range(shape.randint(0, 4))
    ]
    if kind == "parallel":
        return py_trees.composites.Parallel(
            f"par{n}", py_trees.common.ParallelPolicy.SuccessOnOne(), children
        )
    memory = shape.random() < 0.5
    make = sequence if kind == "sequence" else selector
    return make(f"{kind}{n}", memory, children)


def snapshot(root: py_trees.behaviour.Behaviour) -> list[tuple[str, str, str | None]]:
    return [
        (
            node.name,
            node.status.name,
            None if getattr(node, "current_child", None) is None else node.current_child.name,
        )
        for node in root.iterate()
    ]


def _theirs_sequence(
    name: str, memory: bool, children: list[py_trees.behaviour.Behaviour]
) -> py_trees.behaviour.Behaviour:
    return py_trees.composites.Sequence(name, memory, children)


def _pair(
    seed: int,
) -> tuple[py_trees.behaviour.Behaviour, list[str], py_trees.behaviour.Behaviour, list[str]]:
    theirs_log: list[str] = []
    ours_log: list[str] = []
    theirs = random_tree(
        random.Random(seed),
        theirs_log,
        _theirs_sequence,
        lambda n, m, c: py_trees.composites.Selector(n, m, c),
    )
    ours = random_tree(
        random.Random(seed),
        ours_log,
        lambda n, m, c: Sequence(n, m, c),
        lambda n, m, c: Selector(n, m, c),
    )
    return theirs, theirs_log, ours, ours_log


@pytest.mark.parametrize("seed", range(300))
def test_random_trees_tick_as_py_trees_ticks_them(seed: int) -> None:
    theirs, theirs_log, ours, ours_log = _pair(seed)
    for tick in range(12):
        yielded_theirs = [node.name for node in theirs.tick()]
        yielded_ours = [node.name for node in ours.tick()]
        assert yielded_ours == yielded_theirs, (seed, tick)
        assert snapshot(ours) == snapshot(theirs), (seed, tick)
        assert ours_log == theirs_log, (seed, tick)
        assert current_issuer() is None  # no node's name outlives its tick
    theirs.stop(Status.INVALID)
    ours.stop(Status.INVALID)
    assert ours_log == theirs_log
    assert snapshot(ours) == snapshot(theirs)


def test_a_tree_file_builds_the_fast_composites_under_their_own_names() -> None:
    loaded = load_tree(
        {
            "name": "t",
            "root": {
                "type": "sequence",
                "name": "steps",
                "children": [
                    {
                        "type": "selector",
                        "name": "pick",
                        "children": [{"type": "success", "name": "ok"}],
                    },
                ],
            },
        }
    )
    root = loaded.root
    assert type(root) is Sequence and isinstance(root, py_trees.composites.Sequence)
    assert type(root.children[0]) is Selector
    assert isinstance(root.children[0], py_trees.composites.Selector)
    assert type(root).__name__ == "Sequence" and type(root.children[0]).__name__ == "Selector"


class _Answers(py_trees.behaviour.Behaviour):
    """A leaf whose update answers what it is given, a status or not."""

    def __init__(self, answer: object) -> None:
        super().__init__(name="answers")
        self.answer = answer

    def update(self) -> Status:
        return self.answer  # type: ignore[return-value]


class _FastAnswers(_Answers):
    tick = Leaf.tick


@pytest.mark.parametrize("answer", [None, "SUCCESS", 1, [], Status.RUNNING, Status.FAILURE])
def test_an_answer_that_is_no_status_is_invalid_as_in_py_trees(answer: object) -> None:
    theirs, ours = _Answers(answer), _FastAnswers(answer)
    for node in (theirs, ours):
        for _ in node.tick():
            pass
    assert ours.status == theirs.status
    wrapped = [
        FastInverter("inv", _Answers(Status.SUCCESS)),
        py_trees.decorators.Inverter("inv", _Answers(Status.SUCCESS)),
    ]
    for node in wrapped:
        node.update = lambda answer=answer: answer  # type: ignore[method-assign]
        for _ in node.tick():
            pass
    assert wrapped[0].status == wrapped[1].status

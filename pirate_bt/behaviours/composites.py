"""The tree files' ``sequence`` and ``selector``: py_trees' own, ticked with less overhead.

:class:`Sequence` and :class:`Selector` are :class:`py_trees.composites.Sequence` and
:class:`py_trees.composites.Selector` (same class names, ``isinstance`` holds, same
constructor) whose ``tick()`` does what py_trees 2.6's does, step for step, with one
difference of cost only: a child's tick is delegated with ``yield from`` instead of a
Python loop that re-yields every node of the child's subtree and asks of each one
whether it is the child. py_trees' tick generators yield every ticked node up through
each ancestor, so on a mission tree (a dozen levels between the root and the running
leaf) that loop ran for every ancestor of every ticked node: about 2 % of a simulated
mission's instructions (docs/performance.md).

The child is judged after its generator ends, which is the same moment: a py_trees
node's ``tick()`` yields itself last (``Behaviour``, ``Decorator``, ``Composite``, and
the Groot2 hooks' wrappers, :mod:`pirate_bt.interop.groot2_hooks`), so py_trees'
``node is child`` test was true only on the last node. The nodes yielded, their order,
every status and every ``stop()`` are the same as py_trees' own; the test
``tests/test_composites_fast.py`` ticks random trees through both and compares them
tick by tick, against the py_trees that is installed.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import py_trees
from py_trees.common import Status

__all__ = ["Selector", "Sequence"]

_RUNNING = Status.RUNNING
_SUCCESS = Status.SUCCESS
_FAILURE = Status.FAILURE
_INVALID = Status.INVALID


class Sequence(py_trees.composites.Sequence):
    """py_trees' :class:`~py_trees.composites.Sequence`, ticked through ``yield from``."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """Tick the children in turn, as py_trees' ``Sequence.tick()`` does.

        Yields:
            Each ticked node of the subtree, then this sequence.
        """
        self.logger.debug(f"{self.__class__.__name__}.tick()")
        children = self.children
        index = 0
        if self.status != _RUNNING:
            self.current_child = children[0] if children else None
            for child in children:
                if child.status != _INVALID:
                    child.stop(_INVALID)
            self.initialise()
        elif self.memory and self.current_child is not None:
            index = children.index(self.current_child)
        else:
            self.current_child = children[0] if children else None
        if not children:
            self.current_child = None
            self.stop(_SUCCESS)
            yield self
            return
        for child in itertools.islice(children, index, None):
            yield from child.tick()
            if child.status != _SUCCESS:
                if not self.memory:
                    # invalidate the rest of the sequence (dangling runners)
                    for later in itertools.islice(children, index + 1, None):
                        if later.status != _INVALID:
                            later.stop(_INVALID)
                if child.status != _RUNNING:
                    self.stop(child.status)
                else:
                    self.status = child.status
                yield self
                return
            if index + 1 < len(children):
                self.current_child = children[index + 1]
                index += 1
        self.stop(_SUCCESS)
        yield self


class Selector(py_trees.composites.Selector):
    """py_trees' :class:`~py_trees.composites.Selector`, ticked through ``yield from``."""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """Tick the children by priority, as py_trees' ``Selector.tick()`` does.

        Yields:
            Each ticked node of the subtree, then this selector.
        """
        self.logger.debug(f"{self.__class__.__name__}.tick()")
        children = self.children
        if self.status != _RUNNING:
            self.logger.debug(f"{self.__class__.__name__}.tick() [!RUNNING->reset current_child]")
            self.current_child = children[0] if children else None
            self.initialise()
        if not children:
            self.current_child = None
            self.stop(_FAILURE)
            yield self
            return
        if self.memory:
            assert self.current_child is not None  # as py_trees asserts it
            index = children.index(self.current_child)
            for child in itertools.islice(children, None, index):
                if child.status != _INVALID:
                    child.stop(_INVALID)
        else:
            index = 0
        previous = self.current_child
        for child in itertools.islice(children, index, None):
            yield from child.tick()
            if child.status == _RUNNING or child.status == _SUCCESS:
                self.current_child = child
                if previous is None or previous != child:
                    # a higher priority took over: invalidate every lower one
                    passed = False
                    for other in children:
                        if passed and other.status != _INVALID:
                            other.stop(_INVALID)
                        passed = True if other == child else passed
                if child.status == _SUCCESS:
                    self.stop(child.status)
                else:
                    self.status = child.status
                yield self
                return
        self.stop(_FAILURE)
        self.current_child = children[-1]
        yield self

"""A path through a network is a value (a frozen dataclass): equal paths hash alike,
so a planner keeps them in a set or as a dict's keys. ``hash(net.main_path())``
raised *unhashable type: 'dict'* (its tee choices)."""

from __future__ import annotations

import pirate_bt


def test_equal_paths_hash_alike_and_others_are_told_apart() -> None:
    lab = pirate_bt.load_network("lab")
    again = pirate_bt.load_network("lab")
    branch = lab.path({"tee-1": "branch"})
    seen = {lab.main_path(), again.main_path(), branch, again.path({"tee-1": "branch"})}
    assert seen == {lab.main_path(), branch}
    assert len(seen) == 2
    assert {p: p.length_m for p in lab.paths()}[again.main_path()] == lab.main_path().length_m

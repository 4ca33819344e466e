"""A node name of millions of characters (a hostile tree file under the 16 MiB cap)
is checked in work bounded by its distinct characters: the checks asked Unicode for
the category of every character, twice, and a tree is checked three times by
``validate``; a 2 MB name took 8 s, a 16 MB one about a minute.
"""

from __future__ import annotations

import unicodedata

import pytest

from pirate_bt.treefile import names
from pirate_bt.treefile.names import name_problem


def _counted(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    asked: list[str] = []
    real = unicodedata.category

    def category(c: str) -> str:
        asked.append(c)
        return real(c)

    monkeypatch.setattr(names.unicodedata, "category", category)
    return asked


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("é" * 1_000_000, None),
        ("w" * 500_000 + "\u00a0" + "w" * 500_000 + "\u2028w", "U+00A0 NO-BREAK SPACE"),
        ("w" * 500_000 + "\u202e" + "\u200b" * 500_000, "U+202E RIGHT-TO-LEFT OVERRIDE"),
        ("w" * 999_999 + "\x1b", "control characters"),
    ],
    ids=["fine", "space", "invisible", "control"],
)
def test_a_huge_name_is_checked_once_per_distinct_character(
    monkeypatch: pytest.MonkeyPatch, name: str, said: str | None
) -> None:
    asked = _counted(monkeypatch)
    problem = name_problem(name)
    if said is None:
        assert problem is None
    else:
        assert problem is not None and said in problem
    assert len(asked) <= 2 * len(set(name))  # 2,000,000 and more before

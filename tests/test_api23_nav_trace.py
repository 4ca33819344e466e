"""A navigation's ``trace=`` is a folder (docs/navigators.md), where a tree's and a
mission's is a file: ``navigate(..., trace="nav.jsonl")`` made a folder named
``nav.jsonl`` with ``navigation.jsonl`` and the step traces in it, without a word.
A name that ends as a trace file does is refused now, before anything connects; a
folder that is there already is taken whatever its name.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt import Observation, Step


class _OneStep:
    def next_step(self, obs: Observation) -> Step | None:
        return Step("straight", distance="0.1 m") if obs.step < 1 else None


@pytest.mark.parametrize(
    ("name", "suffix", "stem"), [("nav.jsonl", ".jsonl", "nav"), ("nav.MCAP", ".mcap", "nav")]
)
def test_a_trace_file_name_is_refused_before_anything_connects(
    tmp_path: Path, name: str, suffix: str, stem: str
) -> None:
    trace = tmp_path / name
    with pytest.raises(pirate_bt.InputError) as refused:
        pirate_bt.navigate(_OneStep(), trace=trace)
    assert str(refused.value) == (
        f"trace: {trace} is the name of a trace file ({suffix}), but a navigation writes a"
        " folder: navigation.jsonl (every decision) and one trace per step"
        f" (step-001.jsonl, ...); give a folder, e.g. {str(tmp_path / stem)!r}"
    )
    assert list(tmp_path.iterdir()) == []


def test_a_folder_there_already_is_taken_whatever_its_name(tmp_path: Path) -> None:
    trace = tmp_path / "old.jsonl"
    trace.mkdir()
    result = pirate_bt.navigate(_OneStep(), trace=trace)
    assert result.status == "success", result.why
    assert (trace / "navigation.jsonl").is_file()

"""Checking a campaign spec (``pirate-bt validate SPEC``, and ``pirate-bt campaign``
before any case) loads each run's tree with its parameters once and each robot file
once, however many cases name them: 10 runs over 100 robot files (1,000 cases)
loaded every run's tree once per run and again once per case, and each robot file
twice: 36 s of ``validate``. A robot that refuses a run's tree is still told at its
entry, in the loader's words."""

from __future__ import annotations

import shutil
from collections import Counter
from pathlib import Path
from typing import BinaryIO

import pytest

import pirate_bt.yamlfile
from pirate_bt.campaign.run import validate_campaign_file
from pirate_bt.errors import ValidationFailed
from pirate_bt.resources import default_robot_path

ROBOTS = 4
RUNS = 3


def _spec(folder: Path, robots: list[str]) -> Path:
    lines = ["name: many", "runs:"]
    for i in range(1, RUNS + 1):
        lines.append(
            f"  - {{name: s{i}, tree: straight, network: straight, params: {{distance: {i} m}}}}"
        )
    lines += ["robots:", *(f"  - {r}" for r in robots), "seeds: {start: 0, count: 1}"]
    spec = folder / "many.campaign.yaml"
    spec.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return spec


def _counting_reads(monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    """How often each YAML file is read (and parsed) from now on, by its resolved path."""
    reads: Counter[str] = Counter()
    read_at_most = pirate_bt.yamlfile.read_at_most

    def counted(stream: BinaryIO, limit: int) -> bytes:
        reads[str(Path(getattr(stream, "name", "?")).resolve())] += 1
        return read_at_most(stream, limit)

    monkeypatch.setattr(pirate_bt.yamlfile, "read_at_most", counted)
    return reads


def test_checking_a_spec_reads_a_tree_once_per_run_and_each_robot_file_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    names = []
    for i in range(ROBOTS):
        shutil.copy(default_robot_path(), tmp_path / f"robot{i}.yaml")
        names.append(f"robot{i}.yaml")
    spec = _spec(tmp_path, names)
    reads = _counting_reads(monkeypatch)
    validate_campaign_file(spec)  # 12 cases
    robots = {str((tmp_path / n).resolve()): reads[str((tmp_path / n).resolve())] for n in names}
    assert robots == dict.fromkeys(robots, 1)
    trees = {path: n for path, n in reads.items() if "/trees/" in path}
    assert any(path.endswith("/trees/straight.yaml") for path in trees)
    assert any("/trees/lib/" in path for path in trees)  # its subtrees' files
    # once per run (its parameters differ), not again for every robot (and in the
    # check of the axes): 5 times a run with 4 robots
    assert trees == dict.fromkeys(trees, RUNS)


def test_a_robot_that_refuses_a_tree_is_still_told_at_its_entry(tmp_path: Path) -> None:
    text = default_robot_path().read_text(encoding="utf-8")
    strong = text.replace("min_torque: 0.35 N*m", "min_torque: 0.8 N*m")
    assert strong != text
    for i in range(ROBOTS - 1):
        shutil.copy(default_robot_path(), tmp_path / f"robot{i}.yaml")
    (tmp_path / "strong.yaml").write_text(strong, encoding="utf-8")
    names = [*(f"robot{i}.yaml" for i in range(ROBOTS - 1)), "strong.yaml"]
    spec = _spec(tmp_path, names)
    with pytest.raises(ValidationFailed) as caught:
        validate_campaign_file(spec)
    first = str(caught.value).splitlines()[0]
    # at its robots entry (the last line but one), the run, the tree's clamp in its words
    assert first.startswith(f"{spec}:{3 + RUNS + ROBOTS}:5: ")
    assert "robot 'strong.yaml': run 's1': parameter 'torque': clamp: torque: 0.7 N*m" in first
    assert "is below the minimum clamp torque 0.8 N*m" in first


def test_a_parameter_every_robot_refuses_is_the_run_s_not_the_first_robot_s(
    tmp_path: Path,
) -> None:
    # 'velocity: 0' no robot takes: it was said at the first robot's entry, as that
    # robot's problem ("robot 'robot0.yaml': run 's1': parameter 'velocity': ...")
    for i in range(2):
        shutil.copy(default_robot_path(), tmp_path / f"robot{i}.yaml")
    spec = tmp_path / "v.campaign.yaml"
    spec.write_text(
        "name: v\nruns:\n"
        "  - {name: s1, tree: straight, network: straight,"
        " params: {distance: 1 m, velocity: 0 m/s}}\n"
        "robots: [robot0.yaml, robot1.yaml]\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as caught:
        validate_campaign_file(spec)
    first = str(caught.value).splitlines()[0]
    column = spec.read_text(encoding="utf-8").splitlines()[2].index("velocity: 0") + 1
    assert first.startswith(
        f"{spec}:3:{column}: parameter 'velocity': drive: velocity: must not be 0 (used at "
    ), first

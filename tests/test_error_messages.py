"""Bad files get one clear message per problem, never a validator's internal name.

A corpus of hand-written bad files (one per kind and shape of mistake), checked
through ``pirate-bt validate``, and a sweep that puts wrong shapes (a list, a
mapping, text, a number, nothing) at every place of the bundled files.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.pipes.loader import network_from_data
from pirate_bt.robot.loader import robot_from_data
from pirate_bt.treefile.loader import load_tree
from pirate_bt.yamlfile import load_yaml

REPO = Path(__file__).resolve().parent.parent

# pydantic's internal spellings: core-schema names, union tags, class names in its
# stock messages, its error-type tags and its documentation links.
LEAK = re.compile(
    r"function-(after|before|wrap|plain)|list\[|dict\[|tuple\[|tagged-union|union\["
    r"|nullable\[|json-or-python|lax-or-strict|\[type=|errors\.pydantic|instance of [A-Z]"
    r"|ValidationError|valid dictionary|model_type|_check\(\)"
)

GUARD = """\
name: guarded
root:
  type: failure_if
  name: guard
  condition: {state: half.middle, value: clamped}
  child: {type: success, name: ok}
"""

CORPUS: dict[str, tuple[str, str]] = {
    # name: (file text, a phrase the one message must contain)
    "guard-unknown-state.yaml": (GUARD, "unknown state value 'half.middle'"),
    "guard-condition-number.yaml": (
        GUARD.replace("{state: half.middle, value: clamped}", "42"),
        "condition: should be a mapping of keys or a list",
    ),
    "guard-list-bad-op.yaml": (
        GUARD.replace(
            "{state: half.middle, value: clamped}",
            "[{state: half.front, op: '=~', value: clamped}]",
        ),
        "op",
    ),
    "tree-param-shape.yaml": (
        "name: t\nroot: {type: wait, name: w, duration: [1, 2]}\n",
        "time quantity",
    ),
    "tree-blackboard-shape.yaml": (
        "name: t\nblackboard: {go: [1]}\nroot: {type: success, name: s}\n",
        "go",
    ),
    "network-segments-text.yaml": ("name: n\nsegments: straight\n", "segments"),
    "robot-boards-mapping.yaml": ("name: r\nboards: {id: 1}\n", "boards"),
    "route-unknown-word.route": ("network lab\nfly to the moon\n", "unknown command 'fly'"),
    "trace-no-tree.jsonl": (
        '{"type":"header","format":"pirate-bt-trace","version":1,"tree":{"name":"x"}}\n',
        "tree",
    ),
    "trace-bad-json.jsonl": ('{"type":"header", nope}\n{"type":"tick"}\n', "1:"),
}


def _messages(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip()]


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_corpus_gives_one_clear_located_message(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    text, phrase = CORPUS[name]
    path = tmp_path / name
    path.write_text(text)
    assert main(["validate", str(path)]) == 2
    lines = _messages(capsys.readouterr().err)
    assert lines, "no message at all"
    assert all(line.startswith(f"{path}:") for line in lines), lines
    assert not [line for line in lines if LEAK.search(line)], lines
    assert any(phrase in line for line in lines), lines


def test_the_issue_example_is_one_message(tmp_path: Path) -> None:
    path = tmp_path / "guard.yaml"
    path.write_text(GUARD)
    with pytest.raises(ValidationFailed) as info:
        load_tree(path)
    (only,) = info.value.errors
    assert "unknown state value 'half.middle'" in str(only)
    assert (only.location.line, only.location.column) == (5, 3)


def _paths(data: Any, at: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    yield at
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _paths(value, (*at, key))
    elif isinstance(data, list):
        for index, value in enumerate(data):
            yield from _paths(value, (*at, index))


def _replaced(data: Any, at: tuple[Any, ...], value: Any) -> Any:
    out = copy.deepcopy(data)
    target = out
    for key in at[:-1]:
        target = target[key]
    target[at[-1]] = value
    return out


WRONG = ([], {}, "x", -1, None, {"zz": 1}, [1])


def _sweep(data: Any, load: Callable[[Any], Any], stride: int) -> list[str]:
    leaks: list[str] = []
    for at in list(_paths(data))[1::stride]:
        for wrong in WRONG:
            try:
                load(_replaced(data, at, wrong))
            except ValidationFailed as exc:
                leaks.extend(str(e) for e in exc.errors if LEAK.search(str(e)))
    return leaks


@pytest.mark.parametrize(
    ("source", "stride"),
    [
        ("hardware/pirate.yaml", 9),
        ("scenarios/lab.yaml", 2),
        ("trees/examples/patrol.yaml", 1),
        ("trees/examples/guarded_wait.yaml", 1),
        ("guard", 1),
    ],
)
def test_no_file_kind_leaks_validator_internals(tmp_path: Path, source: str, stride: int) -> None:
    if source == "guard":
        path = tmp_path / "guard.yaml"
        path.write_text(GUARD.replace("half.middle", "half.front"))
        data = load_yaml(path).data
    else:
        data = load_yaml(REPO / source).data
    load: Callable[[Any], Any]
    if source.startswith("hardware"):
        load = robot_from_data
    elif source.startswith("scenarios"):
        load = network_from_data
    else:

        def load(d: Any) -> Any:
            return load_tree(d, use_examples=True)

    assert _sweep(data, load, stride) == []


def test_errors_cross_a_process_boundary_whole() -> None:
    # a process pool (campaigns, benchmarks) or Dask pickles a worker's exception; one
    # that cannot be rebuilt breaks the pool instead of naming the problem
    import pickle

    from pirate_bt.errors import CommandRefused, FrameError, LocatedError, SourceLocation

    located = LocatedError("clamp: torque: too high", SourceLocation("t.yaml", 4, 34))
    for error in (
        located,
        ValidationFailed([located]),
        FrameError("crc", "0x12 != 0x34"),
        CommandRefused("limit", "velocity above the limit", command="Drive(9)"),
    ):
        back = pickle.loads(pickle.dumps(error))
        assert type(back) is type(error) and str(back) == str(error)
    assert pickle.loads(pickle.dumps(located)).location.line == 4

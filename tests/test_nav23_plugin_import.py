"""Session 23: an installed navigator whose module raises as it is imported (a bug at
its top level, a syntax error, a package it imports that is not installed) is refused
in one line that says what was raised and where, in the plug-in's file: it said only
the exception's words (*failed to load: name 'speed' is not defined*), with no type and
no place, and the traceback that had them was never shown."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from pirate_bt.errors import InputError

MODULES = {
    # a bug on its second line
    "nav23_name": "import math\nSPEED = speed * 2\n",
    # a syntax error: said at its line and column
    "nav23_syntax": "class Nav:\n    def next_step(self, obs)\n        return None\n",
    # a package it needs that is not installed: its import line
    "nav23_needs": "import math\nimport no_such_package_23\n",
}


@pytest.fixture
def installed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    from importlib.metadata import EntryPoint

    from pirate_bt.task import navigators as registry

    for module, text in MODULES.items():
        (tmp_path / f"{module}.py").write_text(text)
    monkeypatch.syspath_prepend(str(tmp_path))
    plugins = [
        EntryPoint(
            name=m.removeprefix("nav23_"), value=f"{m}:Nav", group=registry.ENTRY_POINT_GROUP
        )
        for m in MODULES
    ]
    monkeypatch.setattr(registry, "entry_points", lambda group: plugins)
    yield tmp_path
    for module in MODULES:
        sys.modules.pop(module, None)


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("name", "NameError: name 'speed' is not defined (at {folder}/nav23_name.py:2)"),
        ("syntax", "SyntaxError: expected ':' (at {folder}/nav23_syntax.py:2:29)"),
        (
            "needs",
            "ModuleNotFoundError: No module named 'no_such_package_23'"
            " (at {folder}/nav23_needs.py:2)",
        ),
    ],
    ids=["name-error", "syntax-error", "missing-package"],
)
def test_a_plugin_whose_module_raises_as_imported_is_said_with_its_place(
    installed: Path, name: str, said: str
) -> None:
    from pirate_bt.task.navigators import load_navigator

    with pytest.raises(InputError) as refused:
        load_navigator(name)
    assert str(refused.value) == (
        f"navigator {name!r} (nav23_{name}:Nav) failed to load: {said.format(folder=installed)}"
    )


def test_a_plugin_module_that_is_not_there_is_said_as_before(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """No place in a file of the user's: Python's own words, as before."""
    from importlib.metadata import EntryPoint

    from pirate_bt.task import navigators as registry
    from pirate_bt.task.navigators import load_navigator

    plugin = EntryPoint(name="gone", value="nav23_gone:Nav", group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])
    with pytest.raises(InputError) as refused:
        load_navigator("gone")
    assert str(refused.value) == (
        "navigator 'gone' (nav23_gone:Nav) failed to load: No module named 'nav23_gone'"
    )

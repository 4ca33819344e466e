"""Session 21, follow-ups of `pirate-bt navigate` and the API's load_navigator: a
plug-in navigator whose making raises (or exits) is named in one line, exit 2; a
parameter a navigator needs is asked for in the caller's words; a navigator's huge
message is bounded. docs/navigators.md."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import InputError


class RaisesAsMade:
    """A plug-in navigator whose making raises (a bug of its own, not a refusal)."""

    def __init__(self, speed: str = "1") -> None:
        raise RuntimeError(f"no speed {speed}")

    def next_step(self, obs: object) -> None:  # pragma: no cover - never made
        return None


class ExitsAsMade:
    """A plug-in navigator whose making ends the process."""

    def __init__(self, speed: str = "1") -> None:
        sys.exit(0)

    def next_step(self, obs: object) -> None:  # pragma: no cover - never made
        return None


class SaysMuch:
    """A plug-in navigator whose first decision raises with a 1 MB message."""

    def next_step(self, obs: object) -> None:
        raise RuntimeError("x" * 1_000_000 + " the end")


def _plug_in(monkeypatch: pytest.MonkeyPatch, made: type) -> None:
    from importlib.metadata import EntryPoint

    from pirate_bt.task import navigators as registry

    plugin = EntryPoint(
        name="rogue", value=f"{__name__}:{made.__name__}", group=registry.ENTRY_POINT_GROUP
    )
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])


def _line_of(cls: type, text: str) -> int:
    import inspect

    lines, first = inspect.getsourcelines(cls)
    return first + next(i for i, line in enumerate(lines) if text in line)


@pytest.mark.parametrize(
    ("made", "said", "where"),
    [
        # was 'pirate-bt: internal error: RuntimeError: no speed 1 (rerun with --debug)', exit 1
        (RaisesAsMade, "RuntimeError as it was made: no speed 1", "raise RuntimeError"),
        # was exit 0, nothing said and nothing run
        (ExitsAsMade, "SystemExit as it was made: 0", "sys.exit(0)"),
    ],
    ids=["raises", "exits"],
)
def test_a_navigator_whose_making_raises_is_named_with_where_it_raised(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    made: type,
    said: str,
    where: str,
) -> None:
    _plug_in(monkeypatch, made)
    place = f"{__file__.removesuffix('c')}:{_line_of(made, where)}"
    assert main(["navigate", "rogue", "--sim", "straight", "-q"]) == 2
    assert capsys.readouterr().err == f"pirate-bt: navigator 'rogue' raised {said} (at {place})\n"
    with pytest.raises(InputError) as caught:  # the API says the same
        pirate_bt.load_navigator("rogue")
    assert str(caught.value) == f"navigator 'rogue' raised {said} (at {place})"
    with pytest.raises(InputError, match=r"^navigator 'rogue' raised "):
        pirate_bt.navigate("rogue", sim="straight")


def test_a_navigator_whose_module_exits_as_it_loads_is_named(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from importlib.metadata import EntryPoint

    from pirate_bt.task import navigators as registry

    (tmp_path / "exits_on_import.py").write_text("import sys\nsys.exit(3)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    plugin = EntryPoint(name="gone", value="exits_on_import:Nav", group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])
    # its sys.exit(3) ended `navigate` with exit 3 and not a word
    assert main(["navigate", "gone", "--sim", "straight", "-q"]) == 2
    assert capsys.readouterr().err == (
        "pirate-bt: navigator 'gone' (exits_on_import:Nav) failed to load: 3\n"
    )


def test_a_parameter_a_navigator_needs_is_asked_for_in_the_caller_s_words(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # a Python caller was told '(--param segment=...; ...)', an option it has not
    with pytest.raises(InputError) as caught:
        pirate_bt.load_navigator("goal")
    assert str(caught.value) == (
        "navigator 'goal' needs the parameter 'segment' (params={'segment': ...};"
        " it takes: segment)"
    )
    assert main(["navigate", "goal", "--sim", "straight", "-q"]) == 2
    assert capsys.readouterr().err == (
        "pirate-bt: navigator 'goal' needs the parameter 'segment' (--param segment=...;"
        " it takes: segment)\n"
    )


def test_a_navigator_s_huge_message_is_bounded_on_the_terminal_and_in_the_trace(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    _plug_in(monkeypatch, SaysMuch)
    trace = tmp_path / "trace"
    assert main(["navigate", "rogue", "--sim", "straight", "--trace", str(trace)]) == 1
    out, err = capsys.readouterr()
    # it printed the whole message twice (2 MB) and wrote it three times (3 MB)
    assert len(out) + len(err) < 20_000
    assert sum(p.stat().st_size for p in trace.iterdir()) < 50_000
    failed = [line for line in err.splitlines() if line.startswith("pirate-bt: ")]
    assert len(failed) == 1 and "navigator 'rogue' raised RuntimeError: xxx" in failed[0]
    assert re.search(r"\.\.\.x+ the end \(0 steps", failed[0])  # its start and end kept


class HugeStep:
    """A navigator asking for a step of a 1 MB parameter (refused: not a distance)."""

    def next_step(self, obs: object) -> object:
        from pirate_bt import Step

        return Step("straight", distance="1" * 1_000_000 + " m")


class HugeOrigin:
    """A navigator whose origin names a 'file' of 1 MB."""

    origin = ("z" * 1_000_000, 1)

    def next_step(self, obs: Any) -> object:
        from pirate_bt import Step

        return Step("straight", distance="0.1 m") if obs.step < 1 else None


@pytest.mark.parametrize(
    ("navigator", "mapped"), [(HugeStep, False), (HugeOrigin, True)], ids=["step", "origin"]
)
def test_a_navigator_s_huge_texts_are_not_written_whole_into_its_trace(
    tmp_path: Path, navigator: type, mapped: bool
) -> None:
    # the step's 1 MB parameter was written whole into navigation.jsonl; the origin's
    # 'file' headed step-001.jsonl twice (its route's name and source)
    trace = tmp_path / "trace"
    pirate_bt.navigate(navigator(), sim="straight", map="straight" if mapped else None, trace=trace)
    sizes = {p.name: p.stat().st_size for p in trace.iterdir()}
    assert "navigation.jsonl" in sizes
    assert all(size < 100_000 for size in sizes.values()), sizes


def _decides(self: object, obs: object) -> None:
    raise RuntimeError("boom")


@pytest.mark.parametrize("name", ["N" * 1_000_000, "Plan\nner"], ids=["huge", "newline"])
def test_a_navigator_class_s_name_is_one_bounded_line_of_its_summary(name: str) -> None:
    # its summary held a class's name whole: 1 MB, or two lines
    navigator = type(name, (), {"next_step": _decides})()
    result = pirate_bt.navigate(navigator, sim="straight")
    summary = result.summary()
    assert len(summary) < 2_000 and summary.isprintable()
    assert summary.startswith(f"navigator {name[:20]}".replace("\n", "\\n"))
    with pytest.raises(InputError) as caught:  # the class, not an instance: bounded too
        pirate_bt.navigate(type(navigator), sim="straight")
    assert len(str(caught.value)) < 1_000 and str(caught.value).isprintable()


def test_a_campaign_naming_a_navigator_whose_module_exits_is_refused_at_its_run(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from importlib.metadata import EntryPoint

    from pirate_bt.task import navigators as registry

    (tmp_path / "exits_as_listed.py").write_text("import sys\nsys.exit(3)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    plugin = EntryPoint(name="gone", value="exits_as_listed:Nav", group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda group: [plugin])
    spec = tmp_path / "g.campaign.yaml"
    spec.write_text("name: g\nruns:\n  - {name: r, navigator: gone, network: lab}\n")
    # its files' parameters were asked for first, and its sys.exit(3) ended 'validate'
    assert main(["validate", str(spec)]) == 2
    assert capsys.readouterr().err == (
        f"{spec}:3:15: run 'r': navigator 'gone' (exits_as_listed:Nav) failed to load: 3\n"
    )


class ExitsAsRead:
    """A plug-in navigator whose next_step is a property that ends the process."""

    @property
    def next_step(self) -> Any:
        sys.exit(0)


def test_a_navigator_whose_next_step_exits_as_it_is_read_is_named(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _plug_in(monkeypatch, ExitsAsRead)
    place = f"{__file__.removesuffix('c')}:{_line_of(ExitsAsRead, 'sys.exit(0)')}"
    # `navigate` ended with exit 0 and not a word; navigate(ExitsAsRead()) let it out
    assert main(["navigate", "rogue", "--sim", "straight", "-q"]) == 2
    assert capsys.readouterr().err == (
        f"pirate-bt: navigator 'rogue': reading its next_step raised SystemExit: 0 (at {place})\n"
    )
    with pytest.raises(InputError, match=r"^navigator 'ExitsAsRead': reading its next_step"):
        pirate_bt.navigate(ExitsAsRead(), sim="straight")


class CheckRaisesAsRead:
    """A plug-in navigator whose check_map is a property that raises."""

    @property
    def check_map(self) -> Any:
        raise RuntimeError("no check")

    def next_step(self, obs: object) -> None:  # pragma: no cover - never asked
        return None


def test_a_campaign_navigator_whose_check_map_raises_as_it_is_read_is_placed(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    _plug_in(monkeypatch, CheckRaisesAsRead)
    place = f"{__file__.removesuffix('c')}:{_line_of(CheckRaisesAsRead, 'no check')}"
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text("name: c\nruns:\n  - {name: r, navigator: rogue, network: lab}\n")
    # was 'internal error: RuntimeError: no check (rerun with --debug)', exit 1
    assert main(["validate", str(spec)]) == 2
    assert capsys.readouterr().err == (
        f"{spec}:3:15: run 'r': navigator 'rogue': reading its check_map raised"
        f" RuntimeError: no check (at {place})\n"
    )

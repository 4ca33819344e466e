"""Messages that name what the caller gave: the API's argument from Python, the
command's option from the command line.

Before, ``pirate_bt.survey(extend=...)`` said ``survey --extend: ...`` and
``pirate_bt.run_campaign(...)`` said ``use --resume, or another --output``: flags a
planner calling the API never typed. The API now names its arguments (``extend:``,
``resume=True``, ``output=``) and ``pirate-bt survey`` / ``pirate-bt campaign`` their
options, as before.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.campaign import run_campaign
from pirate_bt.cli import main
from pirate_bt.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
NO_STUB = ROOT / "scenarios" / "straight.yaml"  # a network with no tee branch left

SPEC = {
    "name": "w19",
    "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.2 m"}}],
    "max_time": "60 s",
}


def _one_error(capsys: pytest.CaptureFixture[str]) -> str:
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err, captured.err
    return captured.err.strip().removeprefix("pirate-bt: ")


def test_survey_extend_from_the_api_names_the_argument(tmp_path: Path) -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.survey(sim="straight", extend=str(NO_STUB), output=tmp_path / "s.yaml")
    # was: "survey --extend: 'straight' has no tee branch ..." (no file, a flag)
    assert str(caught.value) == (
        f"extend: {str(NO_STUB)!r} (network 'straight') has no tee branch left as a stub:"
        " there is nothing to extend"
    )
    assert not (tmp_path / "s.yaml").exists()


def test_survey_extend_of_no_network_says_what_it_was_given(tmp_path: Path) -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.survey(sim="straight", extend=3, output=tmp_path / "s.yaml")
    # was: "survey --extend: ... not a int"
    assert str(caught.value) == (
        "extend: give a surveyed network file, a Network or a NetworkSpec, not 3"
    )


def test_survey_extend_on_the_command_line_names_the_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s.yaml"
    code = main(["survey", "--sim", "straight", "--extend", str(NO_STUB), "-o", str(out)])
    assert code == 2
    assert _one_error(capsys) == (
        f"--extend: {str(NO_STUB)!r} (network 'straight') has no tee branch left as a stub:"
        " there is nothing to extend"
    )
    assert not out.exists()


def _written(out: Path) -> None:
    out.mkdir()
    (out / "results.jsonl").write_text("not a row\n", encoding="utf-8")


def test_run_campaign_names_its_arguments(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _written(out)
    seen: list[object] = []
    with pytest.raises(InputError) as caught:
        run_campaign(SPEC, output=out, workers=1, on_record=seen.append)
    # was: "... holds 1 line already; use --resume, or another --output"
    assert str(caught.value) == (
        f"{out / 'results.jsonl'} holds 1 line already; use resume=True, or another output="
    )
    assert seen == []
    blocker = tmp_path / "blocker"
    blocker.write_text("mine\n", encoding="utf-8")
    with pytest.raises(InputError) as caught:
        run_campaign(SPEC, output=blocker, workers=1)
    assert str(caught.value) == (
        f"{blocker}: the output is a file, not a folder; give another output="
    )


def test_the_campaign_command_names_its_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "w19.campaign.yaml"
    spec.write_text(
        "name: w19\nruns:\n  - {tree: straight, network: straight,"
        " params: {distance: 0.2 m}}\nmax_time: 60 s\n",
        encoding="utf-8",
    )
    out = tmp_path / "my output=folder"  # a folder's own name is not reworded
    _written(out)
    assert main(["campaign", str(spec), "--output", str(out), "--quiet", "--workers", "1"]) == 2
    assert _one_error(capsys) == (
        f"{out / 'results.jsonl'} holds 1 line already; use --resume, or another --output"
    )

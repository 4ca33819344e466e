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
from pirate_bt.errors import InputError, shown

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
        f"extend: {shown(str(NO_STUB))} (network 'straight') has no tee branch left as a stub:"
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
        f"--extend: {shown(str(NO_STUB))} (network 'straight') has no tee branch left as a"
        " stub:"
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


def test_a_held_folder_and_too_many_cases_name_the_argument_or_the_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The campaign's lock and the ceiling on cases also named ``--output`` from Python."""
    from pirate_bt.campaign.cases import check_max_cases
    from pirate_bt.campaign.paths import campaign_lock
    from pirate_bt.errors import ArgumentValueError

    out = tmp_path / "held"
    out.mkdir()
    with campaign_lock(out):  # another campaign writing there now
        with pytest.raises(InputError) as raised:
            run_campaign(SPEC, output=out, workers=1)
        assert str(raised.value).endswith("wait for it, or give another output=")
        spec = tmp_path / "w19.campaign.yaml"
        spec.write_text(
            "name: w19\nruns:\n  - {tree: straight, network: straight,"
            " params: {distance: 0.2 m}}\nmax_time: 60 s\n",
            encoding="utf-8",
        )
        assert main(["campaign", str(spec), "--output", str(out), "--quiet"]) == 2
        assert _one_error(capsys).endswith("wait for it, or give another --output")
    with pytest.raises(ArgumentValueError, match=r"each into its own output=$"):
        check_max_cases(10**9)
    with pytest.raises(ArgumentValueError, match=r"each into its own --output$"):
        check_max_cases(10**9, "--max-cases")


def test_a_refused_campaign_leaves_the_holders_lock_file_in_place(tmp_path: Path) -> None:
    """A campaign refused because another holds the folder used to remove the holder's
    lock file (the folder held nothing else yet: the holder had just started, or was
    waiting for its scheduler), so a third campaign made a new one and went in beside
    the holder: two campaigns writing one folder."""
    from pirate_bt.campaign.paths import LOCK_NAME, campaign_lock

    out = tmp_path / "held"
    out.mkdir()
    with campaign_lock(out):
        for _ in range(2):  # the second would have found no lock to respect
            with (
                pytest.raises(InputError, match="another campaign is writing there"),
                campaign_lock(out),
            ):
                pass
        assert (out / LOCK_NAME).exists()
    assert not (out / LOCK_NAME).exists()  # the holder leaves the folder as it found it
    with campaign_lock(out):  # and the folder may be taken again
        pass

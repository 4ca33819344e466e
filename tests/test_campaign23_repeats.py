"""Session 23: an axis entry that runs the same cases as one before it is refused at
its place, however it is written: a rate of ``-0.0`` beside ``0``, and a navigator's
file parameter naming one file by two names (``t-joint`` and ``t-joint.route``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("lines", "said"),
    [
        (
            # -0.0 == 0: the same rate, drawn the same (was ok: two groups of one run)
            [
                "  - {name: s, tree: straight, params: {distance: 0.1 m}}",
                "link: {drop: [0, -0.0]}",
            ],
            (4, "-0.0", "link.drop[1] repeats link.drop[0] (0)"),
        ),
        (
            # the bundled route by its name and by its file's name (was ok)
            [
                "  - {name: a, navigator: route, network: t-joint, params: {route: t-joint}}",
                "  - {name: b, navigator: route, network: t-joint, params: {route: t-joint.route}}",
            ],
            (4, "{name: b", "runs[1] repeats runs[0] ('a') under another name"),
        ),
    ],
    ids=["minus-zero-rate", "route-file-by-two-names"],
)
def test_an_entry_that_runs_the_same_cases_as_one_before_it_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], lines: list[str], said: tuple[int, str, str]
) -> None:
    spec = tmp_path / "r.campaign.yaml"
    text = "\n".join(["name: r", "runs:", *lines]) + "\n"
    spec.write_text(text)
    assert main(["validate", str(spec)]) == 2
    line, at, words = said
    column = text.splitlines()[line - 1].index(at) + 1
    assert capsys.readouterr().err.splitlines() == [
        f"{spec}:{line}:{column}: {words}: its cases would run twice and be counted as"
        " independent samples; remove one"
    ]


def test_a_navigator_s_file_parameter_naming_two_files_is_two_points(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Not every file parameter is one point: two route files that differ stay two."""
    source = Path(__file__).parents[1] / "scenarios" / "t-joint.route"
    (tmp_path / "other.route").write_text(
        source.read_text().replace("forward 1 m", "forward 0.9 m")
    )
    spec = tmp_path / "r.campaign.yaml"
    spec.write_text(
        "name: r\nruns:\n"
        "  - {name: a, navigator: route, network: t-joint, params: {route: t-joint}}\n"
        "  - {name: b, navigator: route, network: t-joint, params: {route: other.route}}\n"
    )
    assert main(["validate", str(spec)]) == 0, capsys.readouterr().err

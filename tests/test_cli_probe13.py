"""The command line as a hostile but plausible user meets it (probe 13).

A probe of every ``pirate-bt`` verb on 2026-11-30 with missing, odd and hostile
arguments found what each section below pins down; each test fails without its fix.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.resources import bundled_names

BUNDLED = "bundled trees: " + ", ".join(bundled_names("trees"))

# -- a tree name that is no file: every verb names the bundled trees, as run does ------


@pytest.mark.parametrize(
    "argv",
    [
        ["render", "nosuch", "-o", "x.svg"],
        ["export", "btcpp", "nosuch", "-o", "x.xml"],
        ["validate", "nosuch"],
        ["validate", "--kind", "tree", "nosuch.yaml"],
        ["teleop", "--tree", "nosuch"],
    ],
)
def test_a_tree_that_is_no_file_names_the_bundled_trees(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
) -> None:
    # were "nosuch:1:1: no such file" (teleop: "the console needs a terminal", the tree
    # not looked at), while `run nosuch` listed the trees one can name
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    name = argv[argv.index("nosuch.yaml")] if "nosuch.yaml" in argv else "nosuch"
    assert err.endswith(f"{name}:1:1: no such tree file; {BUNDLED}")
    assert "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_validate_reads_a_bundled_tree_by_its_name_as_run_does(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["validate", "bend"]) == 0  # was "bend:1:1: no such file", exit 2
    assert capsys.readouterr().out.strip().endswith("bend.yaml: ok")


def test_validate_an_empty_name_is_no_name_not_the_working_folder(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["validate", ""]) == 2  # was ".:1:1: is a directory, not a file"
    assert capsys.readouterr().err.strip() == "FILE: the file name is empty"

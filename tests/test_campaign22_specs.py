"""Session 22, hostile campaign specs: each refusal one line naming the spec's file,
line and column, and the entry."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("tree", "said"),
    [
        ("root: [\n", "YAML syntax error"),
        ("\ufeff".encode("utf-16-le").decode("latin-1") + "x", "UTF-16"),
        ("root:\n  type: NoSuchNode\n", "NoSuchNode"),
    ],
    ids=["syntax", "utf-16", "unknown-node"],
)
def test_a_tree_file_that_does_not_validate_is_told_with_the_spec_entry_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tree: str, said: str
) -> None:
    (tmp_path / "bad.yaml").write_bytes(tree.encode("latin-1"))
    spec = tmp_path / "s.campaign.yaml"
    text = "name: h\nruns:\n  - {name: a, tree: straight, params: {distance: 0.1 m}}\n"
    text += "  - {name: b, tree: bad.yaml}\n"
    spec.write_text(text)
    out = tmp_path / "out"
    for argv in (["validate", str(spec)], ["campaign", str(spec), "-q", "--output", str(out)]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        lines = err.splitlines()
        assert lines and said in err
        # the tree file's own place first, as before; which run of the spec named the
        # tree was left to guess, as it was for a network, map, robot or route
        column = text.splitlines()[3].index("tree: bad") + 1  # its key, as a network's
        for line in lines:
            assert line.startswith(
                f"{'pirate-bt: ' if argv[0] == 'campaign' else ''}{tmp_path / 'bad.yaml'}:"
            )
            assert line.endswith(f" (named by runs[1].tree at {spec}:4:{column})")
    assert not out.exists()


def test_a_tree_file_of_a_spec_given_as_data_is_told_with_its_entry(tmp_path: Path) -> None:
    from pirate_bt import run_campaign
    from pirate_bt.errors import InputError

    (tmp_path / "bad.yaml").write_text("root: [\n")
    with pytest.raises(InputError) as refused:
        run_campaign({"name": "h", "runs": [{"tree": "bad.yaml"}]}, base=tmp_path)
    assert str(refused.value).endswith(" (named by campaign spec: runs[0].tree)")


def _rows() -> list[dict[str, object]]:
    return [
        {"id": f"{i:06d}-h22", "index": i, "run": "r", "seed": i, "drop": 0.1}
        | {"outcome": "success", "reason": "fine", "sim_time_s": 1.0}
        for i in range(2)
    ]


def test_a_results_file_an_editor_saved_with_a_bom_keeps_its_first_row(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    import json

    from pirate_bt.campaign import read_rows

    results = tmp_path / "results.jsonl"
    text = "".join(json.dumps(row) + "\n" for row in _rows())
    results.write_bytes(b"\xef\xbb\xbf" + text.encode())  # Notepad's "UTF-8"
    # its first row was 'skipped a line that is not a JSON row': the report lost it, and
    # a --resume ran that case again and rewrote the file without the row
    assert read_rows(results) == _rows()
    assert "skipped" not in caplog.text


def test_a_report_of_runs_named_as_long_as_a_spec_allows_says_no_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import json
    import warnings

    rows = [
        {"id": f"{i:06d}-h22", "index": i, "run": f"run {i} " + "n" * 192, "seed": 0}
        | {"drop": drop, "outcome": "success", "reason": "fine", "sim_time_s": 1.0}
        for i, drop in enumerate([0.0, 0.1, 0.0, 0.1])
    ]
    for row in rows[2:]:
        row["run"] = rows[0]["run"] if row["index"] == 2 else rows[1]["run"]
    assert all(len(str(row["run"])) <= 200 for row in rows)  # a spec's limit
    results = tmp_path / "results.jsonl"
    results.write_text("".join(json.dumps(row) + "\n" for row in rows))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always", UserWarning)
        assert main(["campaign", "report", str(results)]) == 0
    # was '.../report.py:310: UserWarning: Tight layout not applied. ...' and
    # '  fig.tight_layout()' on standard error after the report's lines
    assert [str(w.message) for w in seen if issubclass(w.category, UserWarning)] == []
    assert capsys.readouterr().err == ""
    assert (tmp_path / "success_vs_drop.png").is_file()

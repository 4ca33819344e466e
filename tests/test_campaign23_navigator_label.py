"""Session 23: a navigator run without a name is labelled by the navigator's name, whole.
It was cut as a file name is (at its first '.', after its last '/'), so two installed
navigators named 'nav.fast' and 'nav.slow' were both 'nav', and the spec was refused as
two runs of one name (*runs[0] and runs[1] are both named 'nav'*); the report's group
and a refusal (*run 'no': no navigator named 'no.such.mod'*) named a part of it."""

from __future__ import annotations

from pathlib import Path

from pirate_bt.campaign import campaign_from_data


def test_a_navigator_run_is_labelled_by_the_navigator_s_whole_name(tmp_path: Path) -> None:
    spec = campaign_from_data(
        {
            "name": "n",
            "runs": [
                {"navigator": "nav.fast", "network": "lab"},
                {"navigator": "nav.slow", "network": "lab"},
                {"tree": "straight.yaml", "params": {"distance": "1 m"}},
            ],
        },
        base=tmp_path,
    )
    # a tree or a route by its file's stem, as before
    assert [run.label for run in spec.runs] == ["nav.fast", "nav.slow", "straight"]

"""Session 23: two runs of one name are refused at the second run's own place.

The refusal was placed at ``runs:`` (``c.campaign.yaml:2:1``), the list's key, however far
down the second run was written: the user had to count the runs to find it. It is now
at the second run's ``name`` (or the key its name comes from: its tree, route or
navigator), and says where the first one is; a spec given as data names the second
run's key path.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.campaign import campaign_from_data, load_campaign
from pirate_bt.errors import InputError, ValidationFailed


def _refusal(tmp_path: Path, text: str) -> str:
    path = tmp_path / "c.campaign.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValidationFailed) as caught:
        load_campaign(path)
    assert len(caught.value.errors) == 1
    return str(caught.value.errors[0]).replace(str(path), "FILE")


def test_a_second_run_of_one_name_is_refused_at_its_own_name(tmp_path: Path) -> None:
    text = (
        "name: h\n"
        "runs:\n"
        "  - {name: up, tree: straight, params: {distance: 0.2 m}}\n"
        "  - {tree: straight, network: riser, params: {distance: 0.2 m}}\n"
        "  - {name: up, tree: straight, network: lab, params: {distance: 0.2 m}}\n"
    )
    assert _refusal(tmp_path, text) == (
        "FILE:5:6: runs[0] and runs[2] are both named 'up': give each run a 'name' of its"
        " own (the report's groups are told apart by it) (first at FILE:3:6)"
    )


def test_a_run_named_by_its_file_is_refused_at_the_file_it_is_named_by(
    tmp_path: Path,
) -> None:
    text = (
        "name: h\n"
        "runs:\n"
        "  - tree: straight\n"
        "    params: {distance: 0.2 m}\n"
        "  - network: riser\n"
        "    tree: straight\n"
    )
    assert _refusal(tmp_path, text).startswith(
        "FILE:6:5: runs[0] and runs[1] are both named 'straight'"
    )


def test_a_spec_given_as_data_names_the_second_run_s_key() -> None:
    data = {
        "name": "h",
        "runs": [{"route": "lab"}, {"route": "lab", "network": "lab"}],
    }
    with pytest.raises(InputError) as caught:
        campaign_from_data(data)
    assert str(caught.value).startswith(
        "campaign spec: runs[1].route: runs[0] and runs[1] are both named 'lab'"
    )

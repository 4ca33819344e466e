"""Probe 14 (hostile trees): a number with an exponent is a number, as in YAML 1.2.

PyYAML reads YAML 1.1, where ``1e3`` (no dot, no sign in the exponent), ``1.0e3``,
``1E3`` and ``-.5`` are text; YAML 1.2, the JSON Schema and the user's editor read
them as numbers. A tree that compared a number with ``value: 1e2`` compared it with
the text ``'1e2'`` and failed (``v=5 < '1e2': False``) though it validated; a ``number``
parameter's ``default: 1e3`` was refused; a blackboard ``number`` default of ``2e3``
was the text ``'2e3'``; a campaign's ``drop: [1e-2]`` was "not a number".
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt import simulate_tree
from pirate_bt.cli import main
from pirate_bt.yamlfile import load_yaml_text


@pytest.mark.parametrize(
    ("text", "number"),
    [("1e3", 1000.0), ("1E3", 1000.0), ("1.0e3", 1000.0), ("-2.5e-3", -0.0025), ("-.5", -0.5)],
)
def test_a_plain_number_with_an_exponent_is_a_number(text: str, number: float) -> None:
    doc = load_yaml_text(f"a: {text}\nb: '{text}'\nc: [{text}]\n")
    assert doc.data == {"a": number, "b": text, "c": [number]}


@pytest.mark.parametrize(
    "text", ["1e", "e3", "1.2.3", "1e3s", "0x1p3", "1e3e3", "+-1e3", "09", "-0089"]
)
def test_text_that_only_looks_like_a_number_stays_text(text: str) -> None:
    assert load_yaml_text(f"a: {text}\n").data == {"a": text}


def test_a_key_with_an_exponent_is_still_its_text() -> None:
    assert load_yaml_text("1e3: x\n").data == {"1e3": "x"}


def test_a_comparison_with_an_exponent_compares_numbers(tmp_path: Path) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n"
        "  v: {type: number, default: 5}\n"
        "  w: {type: number, default: 2e3}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: check_blackboard, key: v, op: '<', value: 1e2}\n"
        "    - {type: check_blackboard, key: w, op: '>', value: 300}\n",
        encoding="utf-8",
    )
    result = simulate_tree(tree)
    assert result.status == "success", result.why


def test_a_number_parameter_default_with_an_exponent_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "params: {x: {type: number, default: 1e3}}\n"
        "blackboard: {v: {type: number}}\n"
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: set_blackboard, key: v, value: $x}\n"
        "    - {type: check_blackboard, key: v, op: '==', value: 1000}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 0, capsys.readouterr().err
    assert simulate_tree(tree).status == "success"


def test_a_campaign_rate_with_an_exponent_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "e.campaign.yaml"
    spec.write_text(
        "name: e\n"
        "runs:\n  - {tree: straight, params: {distance: 0.2 m}}\n"
        "link: {drop: [0, 1e-2]}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(spec)]) == 0, capsys.readouterr().err


@pytest.mark.parametrize("ref", ["other.xml", "other.XML", "other.xml#t"])
def test_a_subtree_ref_to_an_xml_file_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], ref: str
) -> None:
    # it read "no subtree named 'other.xml'" (or "write FILE.yaml#NAME or NAME") though
    # the file is there: a ref takes a YAML tree file only
    (tmp_path / "other.xml").write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="t"><AlwaysSuccess/></BehaviorTree></root>\n',
        encoding="utf-8",
    )
    tree = tmp_path / "t.yaml"
    tree.write_text(f"root: {{type: subtree, ref: '{ref}'}}\n", encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{tree}:1:23: " in err, err
    assert "BehaviorTree.CPP XML" in err and "import btcpp" in err, err


def test_text_that_yaml_12_reads_as_a_number_stays_text_through_an_import(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the import's YAML writer (YAML 1.1) wrote the text 1e3 plain, which reads back as
    # the number 1000.0 since plain exponents are numbers: it is written quoted
    from pirate_bt import load_tree

    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="m"><Sequence>\n'
        '  <log name="2E5" message="1e3"/><log message="-.5"/>\n'
        "</Sequence></BehaviorTree></root>\n",
        encoding="utf-8",
    )
    out = tmp_path / "t.yaml"
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0, capsys.readouterr().err
    tree = load_tree(out)
    assert [child.params.message for child in tree.spec.children] == ["1e3", "-.5"]
    assert [child.name for child in tree.spec.children] == ["2E5", "log"]


def test_a_network_written_by_the_library_reads_back_with_its_text(tmp_path: Path) -> None:
    # network_yaml (network perturb, remove, insert and a survey's network write with it)
    # used PyYAML's YAML 1.1 writer: a description 1e3 was written plain and read back
    # as the number 1000.0, so the written copy of a valid network did not load
    # ('description: must be text, not 1000.0')
    from pirate_bt.pipes import load_network, network_from_data
    from pirate_bt.pipes.asbuilt import network_yaml

    for text in ("1e3", "-.5", "2E-4", "10", "yes", "1:30"):
        net = network_from_data(
            {
                "name": "n",
                "description": text,
                "diameter": "63 mm",
                "segments": [{"id": "a", "type": "straight", "length": "1 m"}],
            }
        )
        out = tmp_path / "v.yaml"
        out.write_text(network_yaml(net.spec), encoding="utf-8")
        assert load_network(out).spec.description == text

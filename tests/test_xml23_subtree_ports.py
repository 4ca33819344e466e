"""A port pointer (``{x}``) that names no port of the ``<BehaviorTree>`` it is in
(docs/interop.md, Values), said in the XML's words.

BehaviorTree.CPP loads such a file (``xml_parsing.cpp`` remaps whatever a ``<SubTree>``
call gives and checks only that a model's ports without a default are given) and stops
at the first node that reads the key (*unable to find the key*). pirate_bt reads
``{x}`` as the tree's parameter ``x``, declared by the tree's ``<SubTree>`` model in
``<TreeNodesModel>``, and refuses the file at the node; it said so in the YAML's words,
*unknown parameter $x (parameters: $speed)*, a ``$x`` the XML's author never wrote.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_FILE = (
    '<root BTCPP_format="4" main_tree_to_execute="M">\n'
    '<BehaviorTree ID="M"><SubTree ID="S" speed="1 mm/s"/></BehaviorTree>\n'
    '<BehaviorTree ID="S"><Sequence>{body}</Sequence></BehaviorTree>\n'
    "<TreeNodesModel>{models}</TreeNodesModel>\n"
    "</root>\n"
)
_S_MODEL = '<SubTree ID="S"><input_port name="speed" type="velocity"/></SubTree>'


def _said(tmp_path: Path, capsys: pytest.CaptureFixture[str], verb: str, text: str) -> str:
    xml = tmp_path / "t.xml"
    xml.write_text(text, encoding="utf-8")
    args = [verb, "btcpp", str(xml), "-o", str(tmp_path / "t.yaml")] if verb == "import" else []
    code = main(args or [verb, str(xml)])
    assert code == 2
    assert not (tmp_path / "t.yaml").exists()
    return capsys.readouterr().err.replace(str(xml), "t.xml")


@pytest.mark.parametrize("verb", ["validate", "import"])
def test_a_pointer_to_a_port_the_subtree_model_does_not_declare_is_said_in_xml_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], verb: str
) -> None:
    body = '<drive distance="1 m" velocity="{speed}"/><wait duration="{pause}"/>'
    err = _said(tmp_path, capsys, verb, _FILE.format(body=body, models=_S_MODEL))
    prefix = "pirate-bt: " if verb == "import" else ""
    assert err == (
        f"{prefix}t.xml:3:74: {{pause}}: the <BehaviorTree> this node is in has no port"
        " 'pause' (its ports: speed); declare it in that tree's <SubTree> model in"
        ' <TreeNodesModel>: <input_port name="pause"/>\n'
    )


def test_a_tree_without_a_model_is_said_to_declare_no_port(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the Groot2 way of passing a key on: M's own {torque}, which M does not declare
    text = (
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        '<BehaviorTree ID="M"><SubTree ID="S" speed="{torque}"/></BehaviorTree>\n'
        '<BehaviorTree ID="S"><clamp half="front" torque="{speed}"/></BehaviorTree>\n'
        '<TreeNodesModel><SubTree ID="S"><input_port name="speed" type="torque"/>'
        "</SubTree></TreeNodesModel>\n"
        "</root>\n"
    )
    err = _said(tmp_path, capsys, "validate", text)
    assert err == (
        "t.xml:2:22: {torque}: the <BehaviorTree> this node is in has no port 'torque'"
        " (its ports: none declared); declare it in that tree's <SubTree> model in"
        ' <TreeNodesModel>: <input_port name="torque"/>\n'
    )


def test_every_such_pointer_is_said_and_a_yaml_tree_keeps_its_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    body = '<wait duration="{a}"/><wait duration="{b}"/>'
    err = _said(tmp_path, capsys, "validate", _FILE.format(body=body, models=_S_MODEL))
    assert [line.split(": ", 2)[1] for line in err.splitlines()] == ["{a}", "{b}"]
    tree = tmp_path / "y.yaml"
    tree.write_text("name: y\nroot: {type: wait, duration: $pause}\n", encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err == (
        f"{tree}:2:20: unknown parameter $pause (parameters: none declared)\n"
    )

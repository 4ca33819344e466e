"""A key, port or parameter refused as unknown though it looks just like a known one
(docs/trees.md, Names that look alike).

``durаtion`` with a Cyrillic а was *unknown key 'durаtion' (did you mean 'duration'?)*,
and a subtree call's ``spеed`` (Cyrillic е) *unknown parameter 'spеed' (parameters:
speed)*: lines that contradict themselves on a screen. Each now says which character
differs.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_A = "'\u0430' is U+0430 CYRILLIC SMALL LETTER A"
_IE = "'\u0435' is U+0435 CYRILLIC SMALL LETTER IE"
_SUBTREE = (
    "subtrees:\n  s:\n    params: {speed: {type: length, default: 1 m}}\n"
    "    root: {type: wait, duration: 1 s}\n"
)
_MODEL = (
    '<BehaviorTree ID="S"><wait duration="1 s"/></BehaviorTree>\n<TreeNodesModel><SubTree'
    ' ID="S"><input_port name="speed" type="length" default="1 m"/></SubTree></TreeNodesModel>\n'
)


@pytest.mark.parametrize(
    ("name", "text", "said"),
    [
        (
            "t.yaml",
            "name: t\nroot: {type: wait, dur\u0430tion: 1 s}\n",
            f"t.yaml:2:20: wait: unknown key 'dur\u0430tion' (did you mean 'duration'? {_A})",
        ),
        (
            "t.yaml",
            "name: t\nroot: {type: subtree, ref: s, params: {sp\u0435ed: 1 m}}\n" + _SUBTREE,
            "t.yaml:2:40: unknown parameter 'sp\u0435ed' (parameters: speed)"
            f" ('sp\u0435ed' looks like 'speed': {_IE})",
        ),
        (
            "t.xml",
            '<root BTCPP_format="4" main_tree_to_execute="M">\n<BehaviorTree ID="M">'
            '<wait dur\u0430tion="1 s"/></BehaviorTree>\n</root>\n',
            "t.xml:2:22: wait: unknown port 'dur\u0430tion' (ports: duration); did you mean"
            f" 'duration'? ({_A})",
        ),
        (
            "t.xml",
            '<root BTCPP_format="4" main_tree_to_execute="M">\n<BehaviorTree ID="M">'
            f'<SubTree ID="S" sp\u0435ed="1 m"/></BehaviorTree>\n{_MODEL}</root>\n',
            "t.xml:2:22: <SubTree ID='S'>: port 'sp\u0435ed' is not a parameter of 'S'"
            " (parameters: speed; declare them in <TreeNodesModel>)"
            f" ('sp\u0435ed' looks like 'speed': {_IE})",
        ),
    ],
    ids=["yaml-key", "yaml-param", "xml-port", "xml-subtree-port"],
)
def test_a_name_refused_beside_its_look_alike_says_which_character_differs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, text: str, said: str
) -> None:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err.replace(str(path), name) == said + "\n"


def test_a_plain_misspelling_keeps_its_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "t.yaml"
    path.write_text("name: t\nroot: {type: wait, durtion: 1 s}\n", encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"{path}:2:20: wait: unknown key 'durtion' (did you mean 'duration'?)\n"
    )


def test_names_refused_by_thousands_are_compared_in_work_bounded_by_both(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # each unknown parameter of a call compared its skeleton with every declared one's
    # anew: 300 beside 300 made 90,000 skeletons (a hostile file, minutes at its cap)
    from pirate_bt.yamlfile import alike

    made: list[str] = []
    real = alike.skeleton

    def counted(name: str) -> str:
        made.append(name)
        return real(name)

    monkeypatch.setattr(alike, "skeleton", counted)
    declared = "".join(f"      p{i}: {{type: length, default: 1 m}}\n" for i in range(300))
    given = ", ".join(f"q{i}: 1 m" for i in range(300))
    path = tmp_path / "t.yaml"
    path.write_text(
        f"name: t\nroot: {{type: subtree, ref: s, params: {{{given}}}}}\nsubtrees:\n  s:\n"
        f"    params:\n{declared}    root: {{type: wait, duration: 1 s}}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(path)]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 300
    assert len(made) <= 4 * 600

"""What a probe of the BehaviorTree.CPP XML import and export found, each pinned.

- an XML declaration naming a multi-byte encoding (Shift_JIS, UTF-32, ...) was an
  internal error: the file is now read with Python's codec, or refused located;
- a problem at a ``<SubTree>`` call was placed at an ``<input_port>`` of the
  ``<TreeNodesModel>`` (the origin of a freed mapping's ``id()``, reused);
- a bare number's unit hint named the display unit only (``'1.57 deg'`` for what a
  BT.CPP user means as radians);
- ``export_xml(params=[...])`` raised a bare ValueError;
- a named pipe as the input blocked for ever.
"""

from __future__ import annotations

import os
import re
import threading
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ArgumentTypeError, InputError, LocatedError, ValidationFailed
from pirate_bt.interop.btcpp import export_xml, import_xml, tree_to_xml, xml_to_tree
from pirate_bt.interop.btcpp_import import _read
from pirate_bt.treefile.registry import default_registry
from pirate_bt.units import UnitError, parse_quantity
from tests.hostile_support import run_import_cli

ROOT = Path(__file__).resolve().parent.parent
PATROL = ROOT / "trees" / "examples" / "patrol.yaml"

TREE = '<root BTCPP_format="4"><BehaviorTree ID="M"><log message="{text}"/></BehaviorTree></root>\n'


# -- 1. declared encodings expat cannot read itself ---------------------------------------


@pytest.mark.parametrize(
    "encoding", ["Shift_JIS", "EUC-JP", "GB2312", "GBK", "Big5", "EUC-KR", "UTF-7"]
)
def test_a_multi_byte_declared_encoding_is_read_with_python_s_codec(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], encoding: str
) -> None:
    head = f'<?xml version="1.0" encoding="{encoding}"?>\n'
    code, err = run_import_cli(tmp_path, capsys, (head + TREE.format(text="a")).encode(encoding))
    assert (code, err) == (0, [])
    assert xml_to_tree(tmp_path / "t.xml")["root"] == {"type": "log", "message": "a"}


def test_shift_jis_text_is_decoded_and_a_later_problem_placed_in_characters(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (
        '<?xml version="1.0" encoding="Shift_JIS"?>\n'
        '<root BTCPP_format="4"><BehaviorTree ID="M"><Sequence>\n'
        '<log message="日本語のログ"/><wiat/>\n'
        "</Sequence></BehaviorTree></root>\n"
    )
    source = tmp_path / "t.xml"
    source.write_bytes(text.replace("<wiat/>", "").encode("shift_jis"))
    assert xml_to_tree(source)["root"]["children"] == [{"type": "log", "message": "日本語のログ"}]
    code, err = run_import_cli(tmp_path, capsys, text.encode("shift_jis"))
    assert code == 2
    assert err == [f"pirate-bt: {source}:3:24: unknown node type 'wiat'; did you mean 'wait'?"]


def test_a_utf_32_file_is_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = '<?xml version="1.0" encoding="UTF-32"?>\n' + TREE.format(text="ü")
    for data in (text.encode("utf-32"), text.encode("utf-32-be"), text.encode("utf-32-le")):
        code, err = run_import_cli(tmp_path, capsys, data)
        assert (code, err) == (0, [])
        assert xml_to_tree(tmp_path / "t.xml")["root"]["message"] == "ü"
        (tmp_path / "t.yaml").unlink()


def test_a_file_that_is_not_what_its_declaration_says_is_located(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = tmp_path / "t.xml"
    head = '<?xml version="1.0" encoding="UTF-32"?>\n'
    code, err = run_import_cli(tmp_path, capsys, (head + TREE.format(text="a")).encode("ascii"))
    assert (code, err) == (
        2,
        [f"pirate-bt: {source}:1:1: not UTF-32 text, as its XML declaration says (byte 0x3c)"],
    )
    with pytest.raises(InputError, match=r"t\.xml:1:1: not UTF-32 text"):
        xml_to_tree(source)
    # a byte Shift_JIS does not have, on line 2 after two characters of text
    head = '<?xml version="1.0" encoding="Shift_JIS"?>\n'
    data = head.encode() + b'<root a="\x82\xa0\xff"/>\n'
    code, err = run_import_cli(tmp_path, capsys, data)
    assert (code, err) == (
        2,
        [f"pirate-bt: {source}:2:11: not Shift_JIS text, as its XML declaration says (byte 0xff)"],
    )
    # a UTF-32 byte-order mark, then a code point beyond U+10FFFF on line 2
    data = ("<root>\n" + "ab").encode("utf-32") + b"\x00\x00\x11\x00"
    code, err = run_import_cli(tmp_path, capsys, data)
    assert (code, err) == (
        2,
        [f"pirate-bt: {source}:2:3: not UTF-32 text, as its first four bytes say (byte 0x00)"],
    )
    # UTF-7 that decodes to half a surrogate pair
    head = '<?xml version="1.0" encoding="UTF-7"?>\n'
    code, err = run_import_cli(tmp_path, capsys, (head + "<root a='+2D8-'/>\n").encode("ascii"))
    assert (code, err) == (
        2,
        [f"pirate-bt: {source}:2:10: not UTF-7 text, as its XML declaration says (U+D83F)"],
    )


def test_a_declared_codec_that_is_not_a_text_encoding_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    head = '<?xml version="1.0" encoding="rot13"?>\n'
    code, err = run_import_cli(tmp_path, capsys, (head + TREE.format(text="a")).encode("ascii"))
    assert (code, err) == (
        2,
        [f"pirate-bt: {tmp_path / 't.xml'}:1:1: XML declaration: 'rot13' is not a text encoding"],
    )


# -- 2. a problem at a <SubTree> call is placed at the call -------------------------------

CALLS = """<?xml version="1.0"?>
<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main"><Sequence>
<clamp half="rear" torque="0.5 N*m"/>
<SubTree ID="S1" p0="{p0}" p1="{p1}" p2="{p2}"/>
<SubTree ID="S1" p1="{p1}"/>
<SubTree ID="S0" p0="{p0}"/>
<SubTree ID="S1" p0="{p0}" p1="{p1}"/>
<SubTree ID="S1" p0="{p0}" p2="{p2}"/>
</Sequence></BehaviorTree>
<BehaviorTree ID="S0"><Sequence>
<log message="{p0}"/>
<AlwaysSuccess/>
</Sequence></BehaviorTree>
<BehaviorTree ID="S1"><Sequence>
<log message="{p0}"/>
<log message="{p1}"/>
<log message="{p2}"/>
<AlwaysSuccess/>
</Sequence></BehaviorTree>
<TreeNodesModel>
<SubTree ID="S0">
<input_port name="p0" type="string"/>
</SubTree>
<SubTree ID="S1">
<input_port name="p0" type="string"/>
<input_port name="p1" type="string"/>
<input_port name="p2" type="string"/>
</SubTree>
</TreeNodesModel>
</root>
"""


def test_every_mapping_of_the_main_tree_is_placed_in_the_main_tree(tmp_path: Path) -> None:
    source = tmp_path / "t.xml"
    source.write_text(CALLS, encoding="utf-8")
    for _ in range(3):  # the ids Python hands out vary a little from call to call
        _data, where = _read(source, default_registry())
        main_tree = {k: v.line for k, v in where.items() if k[:1] == ("root",)}
        assert main_tree and all(3 <= line <= 9 for line in main_tree.values()), main_tree
        nodes = {k[2]: v.line for k, v in where.items() if k[:2] == ("root", "children")}
        assert nodes == {0: 4, 1: 5, 2: 6, 3: 7, 4: 8, 5: 9}
        # a call's params are placed at the call (its mapping's place is its parent's)
        assert not any(k[:1] == ("root",) and "params" in k for k in where)


def test_an_unknown_parameter_at_a_call_is_reported_at_the_call(tmp_path: Path) -> None:
    source = tmp_path / "t.xml"
    source.write_text(CALLS, encoding="utf-8")
    with pytest.raises(ValidationFailed) as raised:
        import_xml(source, tmp_path / "t.yaml")
    lines = sorted({e.location.line for e in raised.value.errors})
    assert lines == [5, 6, 7, 8, 9], [str(e) for e in raised.value.errors]
    assert all(
        re.match(r"\{p\d\}: the <BehaviorTree> this node is in has no port 'p\d'", e.message)
        for e in raised.value.errors
    )
    assert not (tmp_path / "t.yaml").exists()


def test_the_groot2_style_call_without_a_declared_parameter_is_placed_at_7_7(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = """<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4"
      main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence>
      <log message="start"/>
      <SubTree ID="Hold" torque="{torque}"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Hold">
    <clamp half="front" torque="{torque}"/>
  </BehaviorTree>
  <TreeNodesModel>
    <SubTree ID="Hold">
      <input_port name="torque" type="torque"/>
    </SubTree>
  </TreeNodesModel>
</root>
"""
    code, err = run_import_cli(tmp_path, capsys, text.encode())
    assert (code, err) == (
        2,
        [
            f"pirate-bt: {tmp_path / 't.xml'}:7:7: {{torque}}: the <BehaviorTree> this node"
            " is in has no port 'torque' (its ports: none declared); declare it in that"
            ' tree\'s <SubTree> model in <TreeNodesModel>: <input_port name="torque"/>'
        ],
    )


# -- 4. a bare number's unit hint names the SI unit ---------------------------------------


@pytest.mark.parametrize(
    ("value", "dimension", "hint"),
    [
        ("1.57", "angle", "write it as e.g. '1.57 rad' or '89.95 deg'"),
        (1.57, "angle", "write it as e.g. '1.57 rad' or '89.95 deg'"),
        ("0.05", "velocity", "write it as e.g. '0.05 m/s' or '50 mm/s'"),
        ("1", "angular_velocity", "write it as e.g. '1 rad/s' or '57.3 deg/s'"),
        ("2", "length", "write it as e.g. '2 m'"),
        ("0.5", "torque", "write it as e.g. '0.5 N*m'"),
    ],
)
def test_the_unit_hint_names_the_si_unit_first(value: object, dimension: str, hint: str) -> None:
    with pytest.raises(UnitError) as caught:
        parse_quantity(value, dimension)
    assert str(caught.value) == f"{value!r} needs a unit: {hint}"


def test_a_huge_bare_number_s_hint_has_no_converted_value() -> None:
    with pytest.raises(UnitError) as caught:
        parse_quantity("9" * 400, "angle")
    text = str(caught.value)
    assert text.endswith("characters) rad'") and "deg" not in text and "\n" not in text


def test_the_import_hint_for_si_numbers_is_si(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    body = '<bend module="front" angle="1.57"/>'
    code, err = run_import_cli(
        tmp_path,
        capsys,
        f'<root BTCPP_format="4"><BehaviorTree ID="M">{body}</BehaviorTree></root>'.encode(),
    )
    assert code == 2
    assert err == [
        f"pirate-bt: {tmp_path / 't.xml'}:1:45: bend: angle: '1.57' needs a unit:"
        " write it as e.g. '1.57 rad' or '89.95 deg'"
    ]


# -- 5. export_xml's params is a mapping --------------------------------------------------


@pytest.mark.parametrize("params", [["pause=1 s"], "pause=1 s", 5, [("pause", "1 s")]])
def test_params_that_are_not_a_mapping_are_an_argument_type_error(
    tmp_path: Path, params: object
) -> None:
    for call in (
        lambda: export_xml(PATROL, tmp_path / "t.xml", params=params),  # type: ignore[arg-type]
        lambda: tree_to_xml(PATROL, params=params),  # type: ignore[arg-type]
    ):
        with pytest.raises(ArgumentTypeError) as caught:
            call()
        assert str(caught.value).startswith("params: give a mapping of names to values")
        assert "\n" not in str(caught.value)
    assert list(tmp_path.iterdir()) == []


def test_a_mapping_of_params_is_still_taken(tmp_path: Path) -> None:
    export_xml(PATROL, tmp_path / "t.xml", params={"pause": "1 s"})
    assert 'default="1 s"' in (tmp_path / "t.xml").read_text()


# -- 7. a named pipe as the input ---------------------------------------------------------


def _refused_without_blocking(action: object, fifo: Path) -> BaseException | None:
    """Run ``action`` in a thread; a read that blocks on the pipe is released and failed."""
    outcome: list[BaseException | None] = []

    def run() -> None:
        try:
            action()  # type: ignore[operator]
            outcome.append(None)
        except BaseException as exc:  # handed to the test
            outcome.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(10)
    if thread.is_alive():
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))  # a writer that leaves at once
        thread.join(10)
        pytest.fail("reading the named pipe blocked")
    return outcome[0]


def test_a_named_pipe_as_the_input_is_refused_not_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fifo = tmp_path / "t.xml"
    os.mkfifo(fifo)
    out = tmp_path / "t.yaml"
    error = _refused_without_blocking(lambda: import_xml(fifo, out), fifo)
    assert isinstance(error, LocatedError)
    assert str(error) == f"{fifo}:1:1: is a named pipe, not an XML file"
    error = _refused_without_blocking(lambda: xml_to_tree(fifo), fifo)
    assert isinstance(error, LocatedError)
    codes: list[int] = []
    _refused_without_blocking(
        lambda: codes.append(main(["import", "btcpp", str(fifo), "-o", str(out)])), fifo
    )
    assert codes == [2]
    assert capsys.readouterr().err.splitlines() == [
        f"pirate-bt: {fifo}:1:1: is a named pipe, not an XML file"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.xml"]


def test_an_unknown_encoding_s_long_name_is_cut(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    head = f'<?xml version="1.0" encoding="{"x" * 5000}"?>\n'
    code, err = run_import_cli(tmp_path, capsys, (head + TREE.format(text="a")).encode("ascii"))
    assert (code, err) == (
        2,
        [
            f"pirate-bt: {tmp_path / 't.xml'}:1:1: XML declaration: unknown encoding: "
            + "x" * 40
            + "... (5000 characters)"
        ],
    )


def test_a_multi_byte_encoding_after_a_byte_order_mark_is_refused_located(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = '<?xml version="1.0" encoding="Shift_JIS"?>\n' + TREE.format(text="a")
    for data in (b"\xef\xbb\xbf" + text.encode(), text.encode("utf-16")):
        code, err = run_import_cli(tmp_path, capsys, data)
        assert code == 2 and len(err) == 1
        assert err[0].startswith(
            f"pirate-bt: {tmp_path / 't.xml'}:1:1: XML declaration: the declared encoding"
            " cannot be read here"
        )
        assert err[0].endswith("save the file as UTF-8")


# -- 6. _autoremap, as docs/interop.md says -----------------------------------------------


@pytest.mark.parametrize(("value", "refused"), [("true", True), ("1", True), ("false", False)])
def test_autoremap_true_is_refused_and_false_accepted(
    tmp_path: Path, value: str, refused: bool
) -> None:
    source = tmp_path / "t.xml"
    source.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        f'<BehaviorTree ID="M"><SubTree ID="S" _autoremap="{value}"/></BehaviorTree>\n'
        '<BehaviorTree ID="S"><AlwaysSuccess/></BehaviorTree>\n'
        "</root>\n",
        encoding="utf-8",
    )
    if refused:
        with pytest.raises(LocatedError) as caught:
            xml_to_tree(source)
        assert str(caught.value) == (
            f"{source}:2:22: _autoremap is not supported: remap each port explicitly"
        )
    else:
        assert xml_to_tree(source)["root"] == {"type": "subtree", "ref": "S"}

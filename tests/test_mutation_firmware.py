"""The firmware's mutation catalogue judges honestly (docs/testing.md, The firmware's catalogue).

``tests/mutation/firmware.py`` is not part of ``make test``; these checks of it are:

- every ``/* no mutate */`` comment in the mutated files gives its reason and names
  only rules that exist, and docs/testing.md's table of equivalent firmware mutants
  lists each with the same reason (so their count cannot grow without a reason
  written down);
- such a comment hides the mutants of its line (or, alone on its line, of the next),
  of the rules it names only;
- a judging run that dies of a signal kills its mutant, pytest's own errors do not;
- the host build traps on an index past an array or a layout table, by default.
"""

from __future__ import annotations

import importlib.util
import re
import signal
import subprocess
import sys
from collections import Counter
from pathlib import Path
from types import ModuleType

import pytest
from test_firmware_core import library

ROOT = Path(__file__).resolve().parents[1]
DOCS = (ROOT / "docs" / "testing.md").read_text()

__all__ = ["library"]  # the host build, a fixture shared with test_firmware_core


def load_script() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "firmware_mutation", ROOT / "tests" / "mutation" / "firmware.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


SCRIPT = load_script()


def firmware_section() -> str:
    start = DOCS.index("\n## The firmware's catalogue\n")
    end = DOCS.find("\n## ", start + 1)
    return DOCS[start : end if end >= 0 else len(DOCS)]


def documented_reasons() -> Counter[tuple[str, str]]:
    """``(file, reason)`` of each row of the table of equivalent firmware mutants."""
    rows: Counter[tuple[str, str]] = Counter()
    for line in firmware_section().splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) >= 4 and cells[0].startswith("`firmware/piratebay/"):
            rows[(cells[0].strip("`").removeprefix("firmware/piratebay/"), cells[-1])] += 1
    return rows


def test_every_no_mutate_comment_is_listed_with_its_reason_in_docs_testing() -> None:
    in_code: Counter[tuple[str, str]] = Counter()
    for file in SCRIPT.FILES:
        marked = SCRIPT.pragmas(file, (SCRIPT.FIRMWARE / file).read_text())
        in_code.update((file, reason) for _, reason in marked.values())
    in_docs = documented_reasons()
    assert in_code - in_docs == Counter(), (
        "'/* no mutate */' comments not in docs/testing.md's table of equivalent firmware"
        f" mutants (file, reason): {sorted((in_code - in_docs).elements())}"
    )
    assert in_docs - in_code == Counter(), (
        f"rows of that table with no comment left: {sorted((in_docs - in_code).elements())}"
    )


def test_a_comment_needs_a_reason_and_known_rules() -> None:
    with pytest.raises(SystemExit, match="without ': reason'"):
        SCRIPT.pragmas("x.c", "    if (a < b) { /* no mutate */\n")
    with pytest.raises(SystemExit, match="no such rule"):
        SCRIPT.pragmas("x.c", "    if (a < b) { /* no mutate swap: why */\n")


def test_a_comment_marks_its_line_or_alone_the_next_one_for_the_rules_it_names() -> None:
    text = (
        "int f(int a, int b) {\n"
        "    if (a < b) { /* no mutate: every mutant here */\n"
        "        return 1;\n"
        "    }\n"
        "    /* no mutate off-by-one: only this rule, on the next line */\n"
        "    if (a > b) {\n"
        "        return 2;\n"
        "    }\n"
        "    return 0;\n"
        "}\n"
    )
    marked = SCRIPT.pragmas("x.c", text)
    assert marked == {
        2: (frozenset(SCRIPT.RULES), "every mutant here"),
        6: (frozenset({"off-by-one"}), "only this rule, on the next line"),
    }


def test_the_catalogue_hides_the_named_rules_of_a_marked_line_only() -> None:
    mutants = SCRIPT.catalogue()
    marked = [m for m in mutants if m.equivalent]
    assert marked, "no equivalent mutant in the catalogue"
    for file in SCRIPT.FILES:
        lines = SCRIPT.pragmas(file, (SCRIPT.FIRMWARE / file).read_text())
        for m in mutants:
            if m.file == file:
                rules, reason = lines.get(m.line, (frozenset(), ""))
                assert m.equivalent == (reason if m.rule in rules else None), m


SIGILL_STDERR = """Fatal Python error: Illegal instruction

Current thread 0x00007f (most recent call first):
  File "/tmp/pirate-fw-mutation-x/w1/tests/test_firmware_core.py", line 88 in run
  File "/tmp/pirate-fw-mutation-x/w1/tests/test_firmware_edges.py", line 71 in test_a_seq
  File "/work/.venv/lib/python3.11/site-packages/_pytest/python.py", line 159 in pytest_pyfunc
"""


def test_a_judging_run_that_dies_of_a_signal_kills_its_mutant() -> None:
    assert SCRIPT.verdict(0, "", "") == {"status": "survived"}
    failed = SCRIPT.verdict(1, "FAILED tests/test_firmware_edges.py::test_x - assert\n", "")
    assert failed == {
        "status": "killed",
        "detail": ["FAILED tests/test_firmware_edges.py::test_x - assert"],
    }
    assert SCRIPT.verdict(-signal.SIGILL, "..", SIGILL_STDERR) == {
        "status": "killed",
        "detail": "crashed (signal 4, SIGILL) in tests/test_firmware_edges.py::test_a_seq",
    }
    assert SCRIPT.verdict(-signal.SIGSEGV, "", "")["detail"] == "crashed (signal 11, SIGSEGV)"
    for code in (2, 3, 4, 5):
        assert SCRIPT.verdict(code, "ERROR: usage", "")["status"] == "error"


@pytest.mark.parametrize(
    ("call", "trapped"),
    [
        ("layout_motor(PB_N_MOTORS - 1)", False),
        ("layout_motor(PB_N_MOTORS)", True),
        ("layout_board(PB_N_BOARDS - 1)", False),
        ("layout_board(PB_N_BOARDS)", True),
        ("poller_board_status(PB_N_BOARDS - 1)", False),
        ("poller_board_status(PB_N_BOARDS)", True),
    ],
)
def test_the_host_build_traps_on_an_index_past_a_table(
    library: Path, call: str, trapped: bool
) -> None:
    """HOST_SANITIZE (firmware/piratebay/Makefile), on by default: an index past an array
    of known size, or past the layout's tables, kills the process at once (SIGILL)."""
    header = (library.parent / "layout.h").read_text()
    sizes = {
        name: int(re.search(rf"#define {name} (\d+)", header).group(1))  # type: ignore[union-attr]
        for name in ("PB_N_MOTORS", "PB_N_BOARDS")
    }
    function, argument = call.rstrip(")").split("(")
    name, _, minus = argument.partition(" - ")
    index = sizes[name] - int(minus or 0)
    code = f"import ctypes; ctypes.CDLL({str(library)!r}).{function}({index})"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, check=False)
    assert done.returncode == (-signal.SIGILL if trapped else 0), done.stderr

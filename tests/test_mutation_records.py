"""The mutation run's records are kept honest (docs/testing.md).

``make mutation`` is not part of ``make test``; its result is. These tests fail when

- a module of ``[tool.mutmut]`` gains a ``# pragma: no mutate`` without a reason on the
  same line, or one that docs/testing.md's table of equivalent mutants does not list
  (so the count of pragmas cannot grow without a reason written down);
- the score table in docs/testing.md misses a module, or shows one below 95 %;
- the firmware's catalogue score is not reported beside it.
"""

from __future__ import annotations

import re
import tomllib
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = (ROOT / "docs" / "testing.md").read_text()
MODULES: list[str] = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mutmut"][
    "only_mutate"
]
PRAGMA = re.compile(r"#\s*pragma:\s*no mutate\b(.*)$")
REASON = re.compile(r"^\s*\((.+)\)\s*$")


def pragmas(module: str) -> list[tuple[int, str | None]]:
    """``(line, reason)`` of each pragma in ``module`` (``None``: no reason given)."""
    out = []
    for number, line in enumerate((ROOT / module).read_text().splitlines(), 1):
        found = PRAGMA.search(line)
        if found is not None:
            reason = REASON.match(found.group(1))
            out.append((number, reason.group(1) if reason else None))
    return out


def section(title: str) -> str:
    start = DOCS.index(f"\n## {title}\n")
    end = DOCS.find("\n## ", start + 1)
    return DOCS[start : end if end >= 0 else len(DOCS)]


def documented_reasons() -> Counter[tuple[str, str]]:
    """``(module, reason)`` of each row of the table of equivalent mutants."""
    rows: Counter[tuple[str, str]] = Counter()
    for line in section("Equivalent mutants").splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) >= 4 and cells[0].startswith("`pirate_bt/"):
            rows[(cells[0].strip("`"), cells[-1])] += 1
    return rows


def test_the_listed_modules_exist() -> None:
    assert MODULES, "[tool.mutmut] only_mutate is empty"
    for module in MODULES:
        assert (ROOT / module).is_file(), module


def test_every_pragma_gives_its_reason_on_its_line() -> None:
    bare = [
        f"{module}:{line}"
        for module in MODULES
        for line, reason in pragmas(module)
        if reason is None
    ]
    assert not bare, f"'# pragma: no mutate' without '(reason)': {bare}"


def test_every_pragma_is_listed_with_its_reason_in_docs_testing() -> None:
    in_code: Counter[tuple[str, str]] = Counter(
        (module, reason) for module in MODULES for _, reason in pragmas(module) if reason
    )
    in_docs = documented_reasons()
    assert in_code - in_docs == Counter(), (
        "pragmas not in docs/testing.md's table of equivalent mutants"
        f" (module, reason): {sorted((in_code - in_docs).elements())}"
    )
    assert in_docs - in_code == Counter(), (
        f"rows of that table with no pragma left: {sorted((in_docs - in_code).elements())}"
    )


def test_every_module_has_its_score_and_it_is_at_least_95_percent() -> None:
    block = DOCS.split("<!-- mutation-scores:start -->")[1].split("<!-- mutation-scores:end -->")[0]
    scores = {
        m.group(1): float(m.group(2))
        for m in re.finditer(r"^\| `([^`]+)` \|.*\| ([0-9.]+) % \|$", block, re.M)
    }
    assert set(scores) == set(MODULES)
    low = {module: score for module, score in scores.items() if score < 95.0}
    assert not low, f"below 95 %: {low}"
    assert re.search(r"Measured \d{4}-\d\d-\d\d", block)


def test_the_firmware_catalogue_score_is_reported() -> None:
    block = DOCS.split("<!-- firmware-mutation:start -->")[1].split(
        "<!-- firmware-mutation:end -->"
    )[0]
    assert re.search(r"Measured \d{4}-\d\d-\d\d", block)
    assert re.search(r"^\| all \| \d+ \| \d+ \| \d+ \| \d+ \| [0-9.]+ % \|$", block, re.M)
    for file in ("safety.c", "protocol.c", "frame.c", "cobs.c"):
        assert f"| `{file}` |" in block

"""``make mutation-firmware``: a fixed catalogue of operator mutations of the bridge firmware.

mutmut is for Python; the bridge firmware (``firmware/piratebay``) gets the same idea
from this script. The catalogue is derived from the source by fixed rules, applied
inside function bodies of ``safety.c``, ``protocol.c``, ``frame.c`` and ``cobs.c``
(comments, strings and preprocessor lines are never touched):

``flip``
    a comparison turned to its neighbour: ``<`` and ``<=``, ``>`` and ``>=``, ``==``
    and ``!=`` swapped;
``off-by-one``
    the right operand of a comparison made one larger (``n < N`` becomes
    ``n < (N + 1)``);
``logic``
    ``&&`` and ``||`` swapped, a ``!`` dropped;
``drop``
    a check dropped: the condition of an ``if`` replaced by ``0``.

Each mutant is applied alone to a private copy of the firmware and the repository's
tests, built for the host (``make host``, ``-Werror``: a mutant that does not compile
is *stillborn* and not counted), then judged by the firmware's unit tests
(``tests/test_firmware_core.py``, ``tests/test_firmware_edges.py``) and the conformance
suite against the host build
(``tests/conformance``, ``firmware-host``), with the shared vectors in
``tests/data/link_vectors.json``. The host build checks every index into an array of
known size and traps on one out of bounds (``HOST_SANITIZE`` in the Makefile). A
failing or hanging test kills a mutant, and so does a test process that dies of a
signal (a trap, a segmentation fault: *crashed*); pytest's own errors (exit codes 2 to
5) are *errors*, a broken judge, not a verdict. The score is killed / (killed +
survived); survivors are listed with their place in the source.

A mutant that cannot change anything a user could notice is *equivalent*: the line it
is on says so in a comment, ``/* no mutate: reason */`` (every mutant of the line) or
``/* no mutate flip, off-by-one: reason */`` (those rules' mutants of the line only);
a comment alone on its line speaks of the next line. Such mutants are listed with
their reason and not run; docs/testing.md lists them too
(``tests/test_mutation_firmware.py`` checks that). ``--ignore-pragmas`` runs them
anyway: what a comment hides that is not equivalent must be killed.

``--list`` prints the catalogue; ``--only ID...`` runs some of it; results go to
``mutants/firmware.json``, and with ``--update-docs`` into ``docs/testing.md``.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import datetime
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware" / "piratebay"
FILES = ("safety.c", "protocol.c", "frame.c", "cobs.c")
OUT = ROOT / "mutants" / "firmware.json"
DOCS = ROOT / "docs" / "testing.md"
BLOCK_START = "<!-- firmware-mutation:start -->"
BLOCK_END = "<!-- firmware-mutation:end -->"
TESTS = [
    "tests/test_firmware_core.py",
    "tests/test_firmware_edges.py",
    "tests/conformance",
    "-k",
    "firmware-host or firmware_core or firmware_edges",
]
TIMEOUT_S = 300.0
"""A mutant whose tests take longer than this hangs (it is killed: a bridge that hangs is
noticed)."""

FLIPS = {"<": "<=", "<=": "<", ">": ">=", ">=": ">", "==": "!=", "!=": "=="}
COMPARISON = re.compile(r"(?<![<>=!\-])(<=|>=|==|!=|<|>)(?![<>=])")
LOGIC = re.compile(r"&&|\|\|")
NOT = re.compile(r"!(?!=)")
OPERAND = re.compile(r"\s*(\(?[A-Za-z_][A-Za-z0-9_]*|0x[0-9A-Fa-f]+[uU]?|[0-9]+[uU]?)(?![\w(])")
IF = re.compile(r"\bif\s*\(")
RULES = ("flip", "off-by-one", "logic", "drop")
PRAGMA = re.compile(r"/\*\s*no mutate\b(?P<rules>[^:*]*)(?::\s*(?P<reason>.*?))?\s*\*/")


@dataclasses.dataclass(frozen=True)
class Mutant:
    """One mutation: replace ``old`` at ``start`` (an offset into the file) with ``new``."""

    id: str
    file: str
    line: int
    rule: str
    start: int
    old: str
    new: str
    equivalent: str | None = None
    """The reason its line's ``/* no mutate */`` comment gives (``None``: not marked)."""

    def apply(self, text: str) -> str:
        assert text[self.start : self.start + len(self.old)] == self.old, self
        return text[: self.start] + self.new + text[self.start + len(self.old) :]

    def describe(self) -> str:
        return f"{self.id} {self.file}:{self.line} {self.rule}: {self.old!r} -> {self.new!r}"


def pragmas(file: str, text: str) -> dict[int, tuple[frozenset[str], str]]:
    """``{line: (rules, reason)}`` of the ``/* no mutate */`` comments of one file.

    A comment after code marks its own line; a comment alone on its line, the next.

    Raises:
        SystemExit: a comment without a reason, or naming a rule that does not exist.
    """
    out = {}
    for number, line in enumerate(text.splitlines(), 1):
        found = PRAGMA.search(line)
        if found is None:
            continue
        reason = (found.group("reason") or "").strip()
        if not reason:
            raise SystemExit(f"{file}:{number}: '/* no mutate */' without ': reason'")
        rules = frozenset(r for r in re.split(r"[\s,]+", found.group("rules")) if r)
        unknown = rules - set(RULES)
        if unknown:
            raise SystemExit(f"{file}:{number}: no such rule {sorted(unknown)} (of {RULES})")
        alone = line.lstrip().startswith("/*")
        out[number + 1 if alone else number] = (rules or frozenset(RULES), reason)
    return out


def blank(text: str) -> str:
    """``text`` with comments, strings, chars and preprocessor lines as spaces (same offsets)."""
    out = list(text)
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and text[i:].lstrip(" \t").startswith("#"):
            j = text.find("\n", i)
            j = n if j < 0 else j
            while j > 0 and text[j - 1] == "\\" and j < n:  # continued directive
                j = text.find("\n", j + 1)
                j = n if j < 0 else j
            for k in range(i, j):
                out[k] = " "
            i = j
            continue
        line_start = c == "\n"
        if text.startswith("/*", i):
            j = text.find("*/", i + 2) + 2
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
        elif text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            for k in range(i, j):
                out[k] = " "
            i = j
        elif c in "\"'":
            j = i + 1
            while text[j] != c:
                j += 2 if text[j] == "\\" else 1
            for k in range(i, j + 1):
                out[k] = " "
            i = j + 1
        else:
            i += 1
    return "".join(out)


def function_bodies(code: str) -> list[tuple[int, int]]:
    """Offsets ``(start, end)`` of each function body (``{...}`` after a ``)``)."""
    spans = []
    depth = 0
    start = -1
    for i, c in enumerate(code):
        if c == "{":
            if depth == 0 and code[:i].rstrip().endswith(")"):
                start = i
            depth += 1
        elif c == "}":
            depth -= 1
            if depth == 0 and start >= 0:
                spans.append((start, i + 1))
                start = -1
    return spans


def matching_paren(code: str, open_at: int) -> int:
    depth = 0
    for i in range(open_at, len(code)):
        if code[i] == "(":
            depth += 1
        elif code[i] == ")":
            depth -= 1
            if depth == 0:
                return i
    raise ValueError("unbalanced parentheses")


def catalogue_of(file: str, text: str) -> list[tuple[str, int, str, str]]:
    """``(rule, start, old, new)`` for every mutation of one file, in source order."""
    code = blank(text)
    found: list[tuple[str, int, str, str]] = []
    for lo, hi in function_bodies(code):
        body = code[lo:hi]
        for m in COMPARISON.finditer(body):
            op = m.group(1)
            found.append(("flip", lo + m.start(1), op, FLIPS[op]))
            operand = OPERAND.match(body, m.end(1))
            if (
                operand is not None
                and operand.group(1) not in ("sizeof",)
                and not (operand.group(1).startswith("("))
            ):
                token = operand.group(1)
                found.append(("off-by-one", lo + operand.start(1), token, f"({token} + 1)"))
        for m in LOGIC.finditer(body):
            op = m.group(0)
            found.append(("logic", lo + m.start(), op, "||" if op == "&&" else "&&"))
        for m in NOT.finditer(body):
            found.append(("logic", lo + m.start(), "!", ""))
        for m in IF.finditer(body):
            open_at = lo + m.end() - 1
            close = matching_paren(code, open_at)
            found.append(("drop", open_at + 1, text[open_at + 1 : close], "0"))
    return sorted(found, key=lambda f: (f[1], f[0]))


def catalogue() -> list[Mutant]:
    out = []
    for file in FILES:
        text = (FIRMWARE / file).read_text()
        stem = file.removesuffix(".c")
        marked = pragmas(file, text)
        for i, (rule, start, old, new) in enumerate(catalogue_of(file, text), 1):
            line = text.count("\n", 0, start) + 1
            rules, reason = marked.get(line, (frozenset(), ""))
            equivalent = reason if rule in rules else None
            out.append(Mutant(f"{stem}-{i:03d}", file, line, rule, start, old, new, equivalent))
    return out


def verdict(returncode: int, stdout: str, stderr: str) -> dict[str, object]:
    """What the judging pytest run's exit says of a mutant (``seconds`` not included).

    0: survived. 1 (a test failed) or death by a signal (a bounds trap, a segmentation
    fault: the bridge crashed, which is noticed): killed. pytest's own exit codes 2 to 5
    (interrupted, internal error, usage error, no tests) mean the judge is broken: error.
    """
    if returncode == 0:
        return {"status": "survived"}
    if returncode == 1:
        failed = [ln for ln in stdout.splitlines() if ln.startswith("FAILED")]
        return {"status": "killed", "detail": failed[:1]}
    if returncode < 0:
        try:
            name = f", {signal.Signals(-returncode).name}"
        except ValueError:
            name = ""
        where = re.findall(r'File "[^"]*/(tests/[^"]+)", line \d+ in (test_\w+)', stderr)
        test = f" in {where[0][0]}::{where[0][1]}" if where else ""
        return {"status": "killed", "detail": f"crashed (signal {-returncode}{name}){test}"}
    return {"status": "error", "detail": (stdout + stderr)[-500:]}


# -- running ------------------------------------------------------------------------------------


def workspace(base: Path) -> Path:
    """A private copy of what the firmware tests need: the firmware, tests, robot files."""
    for part in ("firmware/piratebay", "tests", "hardware"):
        shutil.copytree(
            ROOT / part,
            base / part,
            ignore=shutil.ignore_patterns("build", "__pycache__", "mutants", "*.so"),
        )
    return base


def judge(mutant: Mutant | None, base: Path) -> dict[str, object]:
    """Build and test ``mutant`` (``None``: the unmutated firmware) in workspace ``base``."""
    firmware = base / "firmware" / "piratebay"
    original = (firmware / mutant.file).read_text() if mutant else ""  # as copied
    if mutant is not None:
        (firmware / mutant.file).write_text(mutant.apply(original))
    started = time.monotonic()
    try:
        env = {**os.environ, "MAKEFLAGS": ""}
        build = firmware / "build" / "conformance-host"
        shutil.rmtree(firmware / "build", ignore_errors=True)
        made = subprocess.run(
            [
                "make",
                "-s",
                "-C",
                str(firmware),
                "host",
                f"BUILD={build}",
                f"ROBOT={base / 'hardware' / 'pirate.yaml'}",
                f"PIRATE_BT={sys.executable} -m pirate_bt",
            ],
            capture_output=True,
            text=True,
            env=env,
            check=False,
        )
        if made.returncode != 0:
            return {"status": "stillborn", "detail": made.stderr[-300:]}
        try:
            tested = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "pytest",
                    "-x",
                    "-q",
                    "-p",
                    "no:randomly",
                    "-p",
                    "no:cacheprovider",
                    "-n",
                    "0",
                    *TESTS,
                ],
                cwd=base,
                capture_output=True,
                text=True,
                env=env,
                timeout=TIMEOUT_S,
                check=False,
            )
        except subprocess.TimeoutExpired:
            return {"status": "killed", "detail": "timeout", "seconds": TIMEOUT_S}
        seconds = round(time.monotonic() - started, 1)
        return {**verdict(tested.returncode, tested.stdout, tested.stderr), "seconds": seconds}
    finally:
        if mutant is not None:
            (firmware / mutant.file).write_text(original)


def run(mutants: list[Mutant], jobs: int) -> dict[str, dict[str, object]]:
    results: dict[str, dict[str, object]] = {}
    with tempfile.TemporaryDirectory(prefix="pirate-fw-mutation-") as tmp:
        spaces = [workspace(Path(tmp) / f"w{i}") for i in range(jobs)]
        clean = judge(None, spaces[0])
        if clean["status"] != "survived":
            raise SystemExit(f"the unmutated firmware does not pass its tests: {clean}")
        free = list(spaces)
        with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
            pending: dict[concurrent.futures.Future[dict[str, object]], tuple[Mutant, Path]] = {}
            queue = list(mutants)
            while queue or pending:
                while queue and free:
                    mutant, space = queue.pop(0), free.pop()
                    pending[pool.submit(judge, mutant, space)] = (mutant, space)
                done, _ = concurrent.futures.wait(
                    pending, return_when=concurrent.futures.FIRST_COMPLETED
                )
                for future in done:
                    mutant, space = pending.pop(future)
                    free.append(space)
                    results[mutant.id] = {**dataclasses.asdict(mutant), **future.result()}
                    print(f"{results[mutant.id]['status']:>10}  {mutant.describe()}", flush=True)
    return results


def summary(results: dict[str, dict[str, object]]) -> dict[str, dict[str, int]]:
    per_file: dict[str, dict[str, int]] = {}
    for r in results.values():
        counts = per_file.setdefault(str(r["file"]), {})
        counts[str(r["status"])] = counts.get(str(r["status"]), 0) + 1
    return per_file


def table(per_file: dict[str, dict[str, int]]) -> str:
    """The score table; ``mutants`` are those run (equivalent ones are not)."""
    lines = [
        "| file | mutants | stillborn | killed | survived | score |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    total = {"all": 0, "stillborn": 0, "killed": 0, "survived": 0}
    for file in FILES:
        c = per_file.get(file, {})
        n = sum(v for k, v in c.items() if k != "equivalent")
        killed, survived, still = c.get("killed", 0), c.get("survived", 0), c.get("stillborn", 0)
        judged = killed + survived
        for key, value in (("all", n), ("stillborn", still), ("killed", killed)):
            total[key] += value
        total["survived"] += survived
        score = f"{100 * killed / judged:.1f} %" if judged else "-"
        lines.append(f"| `{file}` | {n} | {still} | {killed} | {survived} | {score} |")
    judged = total["killed"] + total["survived"]
    score = f"{100 * total['killed'] / judged:.1f} %" if judged else "-"
    lines.append(
        f"| all | {total['all']} | {total['stillborn']} | {total['killed']} |"
        f" {total['survived']} | {score} |"
    )
    return "\n".join(lines)


def listing(results: dict[str, dict[str, object]], status: str) -> list[str]:
    """``id file:line rule: old -> new`` of the mutants with ``status``, in catalogue order."""
    out = []
    for r in results.values():
        if r["status"] == status:
            text = f"{r['id']} {r['file']}:{r['line']} {r['rule']}: {r['old']!r} -> {r['new']!r}"
            out.append(f"`{text}`: {r['equivalent']}" if status == "equivalent" else f"`{text}`")
    return out


def update_docs(
    text_table: str, survivors: list[str], equivalent: list[str], minutes: float
) -> None:
    text = DOCS.read_text()
    today = datetime.date.today().isoformat()
    listed = "\n".join(f"- {s}" for s in survivors) or "- none"
    hidden = "\n".join(f"- {s}" for s in equivalent) or "- none"
    block = (
        f"{BLOCK_START}\nMeasured {today}, {minutes:.0f} min on this machine:\n\n"
        f"{text_table}\n\nSurvivors:\n\n{listed}\n\n"
        f"Equivalent, not run ({len(equivalent)}; the reason is their"
        f" `/* no mutate */` comment's):\n\n{hidden}\n{BLOCK_END}"
    )
    pattern = re.compile(re.escape(BLOCK_START) + ".*?" + re.escape(BLOCK_END), re.S)
    if not pattern.search(text):
        raise SystemExit(f"{DOCS}: no {BLOCK_START} ... {BLOCK_END} block to update")
    DOCS.write_text(pattern.sub(lambda _: block, text))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2, help="mutants tested at once (default 2)")
    parser.add_argument("--list", action="store_true", help="print the catalogue and stop")
    parser.add_argument("--only", nargs="*", default=None, metavar="ID", help="these mutants")
    parser.add_argument("--update-docs", action="store_true", help="write the score in the docs")
    parser.add_argument(
        "--ignore-pragmas",
        action="store_true",
        help="run the mutants that '/* no mutate */' comments mark equivalent, too",
    )
    args = parser.parse_args(argv)
    mutants = catalogue()
    if args.ignore_pragmas:
        mutants = [dataclasses.replace(m, equivalent=None) for m in mutants]
    if args.list:
        for m in mutants:
            print(m.describe() + (f"  [equivalent: {m.equivalent}]" if m.equivalent else ""))
        print(f"{len(mutants)} mutants, {sum(bool(m.equivalent) for m in mutants)} equivalent")
        return 0
    if args.only:
        unknown = set(args.only) - {m.id for m in mutants}
        if unknown:
            raise SystemExit(f"no such mutants: {sorted(unknown)}")
        mutants = [m for m in mutants if m.id in set(args.only)]
    started = time.monotonic()
    results = run([m for m in mutants if m.equivalent is None], max(1, args.jobs))
    minutes = (time.monotonic() - started) / 60
    for m in mutants:
        if m.equivalent is not None:
            results[m.id] = {**dataclasses.asdict(m), "status": "equivalent"}
    order = {m.id: i for i, m in enumerate(mutants)}
    results = dict(sorted(results.items(), key=lambda item: order[item[0]]))
    per_file = summary(results)
    text_table = table(per_file)
    survivors = listing(results, "survived")
    equivalent = listing(results, "equivalent")
    errors = [r for r in results.values() if r["status"] == "error"]
    print()
    print(text_table)
    for s in survivors:
        print(f"  survived: {s}")
    print(f"  equivalent, not run: {len(equivalent)}")
    for r in errors:
        print(f"  error: {r['id']}: {r.get('detail')}", file=sys.stderr)
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(results, indent=1) + "\n")
    if args.update_docs and not args.only and not args.ignore_pragmas:
        if errors:
            print("not written to the docs: the judge failed on some mutants", file=sys.stderr)
        else:
            update_docs(text_table, survivors, equivalent, minutes)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())

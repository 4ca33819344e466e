"""Benchmarks publish the tables they own; ``docs/performance.md`` is rewritten from them.

A benchmark measures, then calls :func:`publish` with a table it owns::

    from report import publish

    publish("mission", ["figure", "value"], [["speed-up over real time", "144x"]],
            note="Median of 3 runs.")

The table is always printed. When the environment variable ``PIRATE_BENCH_RESULTS``
names a directory (``make bench`` sets it to a fresh temporary one), the figures
also go there as ``NAME.json``, with what the reader of the table needs to judge
them: the machine (cores, CPU model, Python, platform, the load average when the
table was made), the date, the git commit (``+dirty`` when tracked files had
changes) and the exact command that produced them.

The rewriter then puts each result in the document::

    .venv/bin/python benchmarks/report.py --write docs/performance.md RESULTS_DIR

In the document, a table is owned between two marker lines, each alone on its
line::

    <!-- bench:mission -->
    ... replaced by the generated table, headed by one line naming the machine,
    the date, the commit and the command ...
    <!-- /bench:mission -->

Nothing outside the markers is touched, byte for byte. A marker with no fresh
result keeps its old block (the output says so); a result with no marker is
reported as a one-line warning, never dropped silently; markers that do not
pair up (nested, closed twice, never closed, the same name twice) are a one-line
error naming the line, and then nothing is written. The document is written to
a temporary file beside it and moved over it (``os.replace``), so a reader
never sees half of it.

Standard library only: a benchmark imports this before anything else.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import shlex
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
RESULTS_ENV = "PIRATE_BENCH_RESULTS"
"""The environment variable naming the directory results go to (unset: print only)."""
NAME = re.compile(r"[a-z0-9][a-z0-9_.-]*")
MARKER = re.compile(r"^[ \t]*<!--[ \t]*(/?)bench:([^ \t>]*)[ \t]*-->[ \t]*$")
FENCE = re.compile(r"^[ \t]{0,3}(`{3,}|~{3,})")


class MarkerError(ValueError):
    """The document's markers do not pair up; the message is one line naming the line."""


@dataclass(frozen=True)
class Result:
    """One published table and how it was made."""

    name: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    note: str = ""
    source: str = ""
    """The benchmark script that published it."""
    command: str = ""
    date: str = ""
    """ISO date and time, local, to the second."""
    commit: str = ""
    machine: Mapping[str, Any] = field(default_factory=dict)


@dataclass
class Outcome:
    """What :func:`rewrite` did: blocks written, blocks kept, results left out."""

    written: list[str] = field(default_factory=list)
    kept: list[str] = field(default_factory=list)
    unplaced: list[str] = field(default_factory=list)


# --- the machine, the commit, the command -----------------------------------------------


def cpu_model() -> str:
    """The CPU's model name from ``/proc/cpuinfo``, else what ``platform`` knows."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as handle:
            for line in handle:
                key, _, value = line.partition(":")
                if key.strip() in ("model name", "Model", "Hardware", "cpu model"):
                    return " ".join(value.split())
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def machine() -> dict[str, Any]:
    """Cores, CPU model, Python version, platform and the 1-minute load average now."""
    try:
        load: float | None = round(os.getloadavg()[0], 2)
    except OSError:
        load = None
    return {
        "cores": os.cpu_count() or 0,
        "cpu": cpu_model(),
        "python": platform.python_version(),
        "platform": f"{platform.system()} {platform.release()} {platform.machine()}",
        "load": load,
    }


def git_commit(repo: Path = REPO) -> str:
    """The short hash of HEAD, with ``+dirty`` when tracked files differ from it."""

    def git(*args: str) -> str:
        out = subprocess.run(
            ["git", "-C", str(repo), *args], capture_output=True, text=True, check=True
        )
        return out.stdout.strip()

    try:
        head = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def command_line(argv: Sequence[str] | None = None) -> str:
    """The command that runs this process, with the interpreter relative to the repository."""
    exe = Path(sys.executable)
    try:
        shown = str(exe.relative_to(Path.cwd()))
    except ValueError:
        shown = str(exe)
    return shlex.join([shown, *(sys.argv if argv is None else argv)])


def no_arguments(doc: str | None, argv: Sequence[str] | None = None) -> None:
    """Parse the command line of a benchmark that takes no arguments.

    ``--help`` prints the script's docstring (what it measures, how long it takes)
    and exits 0; any argument is refused with argparse's one-line error (exit 2),
    before a single figure is measured, instead of being ignored by a run of minutes.
    """
    parser = argparse.ArgumentParser(
        description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.parse_args(argv)


def positive(text: str) -> int:
    """An argparse type: a count of runs, pairs or cases, 1 or more."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: at least 1")
    return value


def positive_number(text: str) -> float:
    """An argparse type: a finite number above 0 (a scale of the as-built bounds)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: a number above 0")
    return value


def skip_without(modules: Sequence[str], extra: str) -> None:
    """Exit 0 with one line, ``skipped: ...``, when an optional module cannot be imported.

    A benchmark of an optional feature (Groot2, Foxglove, ROS 2, Dask, plots) calls
    this before importing it: without the extra installed it publishes nothing, as
    ``bench_firmware.py`` without simavr, and ``make bench`` goes on (the page's
    table for it is kept, and the rewriter says so).
    """
    import importlib

    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError as exc:
            print(
                f"skipped: {name} cannot be imported ({exc}); install the {extra!r} extra:"
                f" .venv/bin/pip install -e '.[{extra}]'"
            )
            raise SystemExit(0) from None


# --- publishing ---------------------------------------------------------------------------


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """The lines of a Markdown table (a ``|`` in a cell is escaped)."""

    def line(cells: Sequence[str]) -> str:
        text = (" ".join(str(c).split()).replace("|", r"\|") for c in cells)
        return "|" + "|".join(f" {t} " if t else " " for t in text) + "|"

    return [line(header), "|" + "---|" * len(header), *(line(r) for r in rows)]


def publish(
    name: str,
    header: Sequence[str],
    rows: Sequence[Sequence[object]],
    *,
    note: str = "",
    results: Path | str | None = None,
) -> Path | None:
    """Print a table a benchmark owns and, when results are collected, save it.

    Args:
        name: the block's name in the document (``<!-- bench:NAME -->``): lower-case
            letters, digits, ``_``, ``.``, ``-``.
        header: the column titles.
        rows: the rows, as many cells each as ``header`` has; cells are shown as text.
        note: one paragraph printed under the table (what was measured, how many runs).
        results: the directory to save ``NAME.json`` in; default the environment
            variable ``PIRATE_BENCH_RESULTS``; neither: print only.

    Returns:
        The file written, or None when results are not collected.

    Raises:
        ValueError: a bad name, or a row whose length is not the header's.
    """
    if not NAME.fullmatch(name):
        raise ValueError(f"bad result name {name!r}: lower-case letters, digits, _ . - only")
    cells = [[str(c) for c in row] for row in rows]
    for row in cells:
        if len(row) != len(header):
            raise ValueError(f"{name}: a row has {len(row)} cells for {len(header)} columns")
    print()
    print("\n".join(markdown_table(header, cells)))
    if note:
        print(f"\n{note}")
    folder = results if results is not None else os.environ.get(RESULTS_ENV) or None
    if folder is None:
        return None
    data = {
        "name": name,
        "header": list(header),
        "rows": cells,
        "note": note,
        "source": Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "",
        "command": command_line(),
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "commit": git_commit(),
        "machine": machine(),
    }
    path = Path(folder) / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    _replace_atomically(path, json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    return path


def load_results(folder: Path) -> dict[str, Result]:
    """Every ``NAME.json`` of a results directory, by name.

    Raises:
        ValueError: a file that is not a result (one line naming it).
    """
    found: dict[str, Result] = {}
    for path in sorted(folder.glob("*.json")):
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            result = Result(
                name=str(data["name"]),
                header=tuple(str(h) for h in data["header"]),
                rows=tuple(tuple(str(c) for c in row) for row in data["rows"]),
                note=str(data.get("note", "")),
                source=str(data.get("source", "")),
                command=str(data.get("command", "")),
                date=str(data.get("date", "")),
                commit=str(data.get("commit", "")),
                machine=dict(data.get("machine", {})),
            )
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{path}: not a benchmark result ({exc})") from None
        found[result.name] = result
    return found


# --- the document -------------------------------------------------------------------------


def _escape(text: str) -> str:
    return re.sub(r"([*_`\\])", r"\\\1", text)


def header_line(result: Result) -> str:
    """The line above a generated table: date, commit, machine and command."""
    m = result.machine
    parts = [f"{m.get('cores', '?')} cores", _escape(str(m.get("cpu", "unknown CPU")))]
    parts.append(f"Python {m.get('python', '?')}")
    parts.append(_escape(str(m.get("platform", "?"))))
    if m.get("load") is not None:
        parts.append(f"load average {m['load']} at the end")
    date = result.date.split("T")[0] or "an unknown date"
    commit = result.commit or "unknown"
    return (
        f"*Measured on {date} at commit {commit}, on {', '.join(parts)}:"
        f" `{result.command or result.source}`.*"
    )


def render(result: Result, newline: str = "\n") -> str:
    """The text that goes between a block's markers (blank lines around the table)."""
    lines = ["", header_line(result), "", *markdown_table(result.header, result.rows), ""]
    if result.note:
        lines += [" ".join(result.note.split()), ""]
    return "".join(line + newline for line in lines)


def find_blocks(lines: Sequence[str], where: str = "document") -> dict[str, tuple[int, int]]:
    """The marked blocks of a document's lines: name -> (opening, closing) line index.

    Lines in fenced code blocks are not markers.

    Raises:
        MarkerError: markers that do not pair up; the message names the line (1-based).
    """
    blocks: dict[str, tuple[int, int]] = {}
    first_seen: dict[str, int] = {}
    open_name: str | None = None
    open_at = 0
    fence = ""
    for index, raw in enumerate(lines):
        text = raw.rstrip("\r\n")
        number = index + 1
        fenced = FENCE.match(text)
        if fence:
            if fenced and fenced.group(1)[0] == fence[0] and len(fenced.group(1)) >= len(fence):
                fence = ""
            continue
        if fenced:
            fence = fenced.group(1)
            continue
        match = MARKER.match(text)
        if match is None:
            continue
        closing, name = match.group(1) == "/", match.group(2)
        tag = f"<!-- {'/' if closing else ''}bench:{name} -->"
        if not NAME.fullmatch(name):
            raise MarkerError(f"{where}:{number}: {tag}: a bad block name")
        if not closing:
            if open_name is not None:
                raise MarkerError(
                    f"{where}:{number}: {tag} opens inside bench:{open_name}"
                    f" (opened at line {open_at + 1}, not closed)"
                )
            if name in first_seen:
                raise MarkerError(
                    f"{where}:{number}: bench:{name} appears twice"
                    f" (first at line {first_seen[name] + 1})"
                )
            first_seen[name] = index
            open_name, open_at = name, index
        elif open_name is None:
            raise MarkerError(f"{where}:{number}: {tag} closes a block that is not open")
        elif name != open_name:
            raise MarkerError(
                f"{where}:{number}: {tag} closes bench:{open_name}"
                f" (opened at line {open_at + 1}) under another name"
            )
        else:
            blocks[name] = (open_at, index)
            open_name = None
    if open_name is not None:
        raise MarkerError(f"{where}:{open_at + 1}: <!-- bench:{open_name} --> is never closed")
    return blocks


def rewrite_text(
    text: str, results: Mapping[str, Result], where: str = "document"
) -> tuple[str, Outcome]:
    """The document with every marked block that has a result replaced.

    Raises:
        MarkerError: markers that do not pair up.
    """
    lines = text.splitlines(keepends=True)
    blocks = find_blocks(lines, where)
    outcome = Outcome()
    out: list[str] = []
    cursor = 0
    for name, (start, end) in sorted(blocks.items(), key=lambda item: item[1]):
        if name not in results:
            outcome.kept.append(name)
            continue
        opening = lines[start]
        newline = "\r\n" if opening.endswith("\r\n") else "\n"
        out += lines[cursor : start + 1]
        out.append(render(results[name], newline))
        cursor = end
        outcome.written.append(name)
    out += lines[cursor:]
    outcome.unplaced = sorted(set(results) - set(blocks))
    return "".join(out), outcome


def _replace_atomically(path: Path, text: str) -> None:
    """Write ``text`` to a temporary file beside ``path``, then move it over ``path``."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        try:
            os.chmod(tmp, path.stat().st_mode & 0o7777)
        except FileNotFoundError:
            os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def rewrite(doc: Path, results: Mapping[str, Result] | Path) -> Outcome:
    """Rewrite the marked blocks of ``doc`` that have a result, atomically.

    Args:
        doc: the Markdown document (``docs/performance.md``).
        results: the results by name, or a results directory.

    Returns:
        Which blocks were written and kept, and which results had no block.

    Raises:
        MarkerError: markers that do not pair up (the document is not written).
        ValueError: a results file that is not a result.
    """
    if isinstance(results, Path):
        results = load_results(results)
    with open(doc, encoding="utf-8", newline="") as handle:
        text = handle.read()
    new, outcome = rewrite_text(text, results, str(doc))
    if outcome.written and new != text:
        _replace_atomically(doc, new)
    return outcome


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Rewrite the marked tables of a document from benchmark results."
    )
    parser.add_argument("--write", type=Path, required=True, metavar="DOC", help="the document")
    parser.add_argument("results", type=Path, help="the directory the benchmarks published to")
    args = parser.parse_args(argv)
    if not args.results.is_dir():
        print(f"error: {args.results}: no such results directory", file=sys.stderr)
        return 2
    try:
        results = load_results(args.results)
        outcome = rewrite(args.write, results)
    except (MarkerError, ValueError, OSError) as exc:
        print(f"error: {exc}; {args.write} not written", file=sys.stderr)
        return 2
    for name in outcome.written:
        r = results[name]
        print(f"{args.write}: bench:{name} rewritten ({r.source or 'unknown source'}, {r.date})")
    for name in outcome.kept:
        print(f"{args.write}: bench:{name} kept as it was (no fresh result)")
    for name in outcome.unplaced:
        print(
            f"warning: result {name!r} ({results[name].source or 'unknown source'}) has no"
            f" <!-- bench:{name} --> block in {args.write}: not written",
            file=sys.stderr,
        )
    if not results:
        print(f"{args.write}: no results in {args.results}; nothing written")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

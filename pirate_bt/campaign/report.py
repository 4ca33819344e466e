"""The campaign report: per-group statistics as Markdown and HTML, rows as CSV, plots.

Written at the end of every campaign and by ``pirate-bt campaign report
RESULTS``. Each file is written beside its final name and renamed into place,
so an interrupted report never leaves half a file. Only fixed names are joined
onto the report's folder; the spec's texts (the title, run and group names) are
escaped where they are shown (HTML, plot labels) and never name a file.
"""

from __future__ import annotations

import csv
import errno
import html
import io
import json
import os
import re
import warnings
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pirate_bt.atomic import write_atomically
from pirate_bt.campaign.stats import GroupStats, group_stats, percentile
from pirate_bt.errors import InputError

__all__ = ["CSV_COLUMNS", "write_report"]

CSV_COLUMNS = (
    "id", "index", "run", "tree", "route", "navigator", "blind", "network", "map", "as_built",
    "as_built_scale", "robot", "params", "sim_faults", "drop", "corrupt", "dup", "seed",
    "outcome", "reason", "failing_node", "sim_time_s", "wall_time_s", "ticks", "steps",
    "distance_m", "belief_m", "truth_m", "violations", "damage", "refusals", "clips",
    "safe_states", "estops",
    "retries", "link_failures", "crc_errors", "duplicates", "frames_dropped", "overruns",
    "violation_kinds", "damage_kinds", "trace",
)  # fmt: skip
"""The columns of ``results.csv``: the case, its outcome and first cause, a navigator's
steps and distance driven, where a mission or navigation ended by the belief and by the
truth, and the run's counters
(:class:`~pirate_bt.safety.tally.Counters`; the kinds as JSON objects)."""

_COUNTERS = (
    ("violations", "violations"), ("damage", "damage"), ("refusals", "refusals"),
    ("clips", "clips"), ("safe_states", "safe states"), ("estops", "e-stops"),
    ("retries", "retries"),
    ("link_failures", "link failures"), ("crc_errors", "CRC errors"),
    ("duplicates", "duplicates"), ("frames_dropped", "frames dropped"),
    ("overruns", "tick overruns (wall time)"),
)  # fmt: skip
"""The counters the report sums, with their names in it. ``overruns`` are ticks that took
longer than their wall-clock budget: they depend on the machine and its load, so two runs
of one case may differ in them (every other counter is a function of the case)."""
_KINDS = {"violations": "violation_kinds", "damage": "damage_kinds"}


def _replace(path: Path, text: str | bytes) -> Path:
    data = text if isinstance(text, bytes) else text.encode("utf-8")
    try:
        write_atomically(path, lambda stream: stream.write(data))
    except OSError as exc:
        raise _unwritable(path, exc) from None
    return path


def _unwritable(path: Path, exc: OSError) -> InputError:
    # A full disk said only "No space left on device", naming no file. Nothing is
    # left of the attempt (write_atomically; a plot's part file is removed).
    results = path.parent / "results.jsonl"
    # "make room" was said of a read-only folder too, where no room helps
    fix = (
        "make room"
        if exc.errno in (errno.ENOSPC, errno.EDQUOT)
        else "make the folder writable"
        if exc.errno in (errno.EROFS, errno.EACCES, errno.EPERM)
        else "fix that"
    )
    return InputError(
        f"{path}: cannot write the report: {exc.strerror or exc}; the rows stay in"
        f" {results}: {fix}, then `pirate-bt campaign report {results}`"
    )


def _csv(rows: Sequence[dict[str, Any]]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, extrasaction="ignore")
    writer.writeheader()
    for row in rows:
        flat = dict(row)
        for key in ("params", "violation_kinds", "damage_kinds"):
            flat[key] = json.dumps(row.get(key) or {}, sort_keys=True)
        flat["sim_faults"] = " ".join(row.get("sim_faults") or [])
        writer.writerow({k: _cell(v) for k, v in flat.items()})
    return buf.getvalue()


_FORMULA = ("=", "+", "-", "@", "\t", "\r")
"""What a spreadsheet takes a text cell starting with for a formula (CSV injection)."""


def _cell(value: Any) -> Any:
    """A text cell a spreadsheet would run as a formula (a run named ``=HYPERLINK(...)``,
    a reason starting with ``-``) with a leading apostrophe, which spreadsheets show as
    text; numbers, booleans and every other text stay as they are."""
    if isinstance(value, str) and value.startswith(_FORMULA):
        return "'" + value
    return value


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def _seconds(x: float | None) -> str:
    return "-" if x is None else f"{x:.1f}"


def _interval(g: GroupStats) -> str:
    """The success rate's 95 % Wilson interval over the group's distinct runs; a group
    whose seeds all repeat one run has none to give (30 identical runs said
    88.6–100.0 %, as if they were 30 samples)."""
    if g.deterministic:  # rows of one run that differ: a wall-time limit, a crash
        split = ", its rows disagree (wall time or a crash)" if 0 < g.success < g.n else ""
        return f"deterministic: 1 distinct run of {g.n}{split}"
    low, high = g.interval
    said = f"{100 * low:.1f}–{100 * high:.1f} %"
    return said if g.distinct_runs >= g.n else f"{said} ({g.distinct_runs} distinct runs of {g.n})"


def _table(groups: Sequence[GroupStats]) -> list[list[str]]:
    head = ["group", "runs", "success", "95 % Wilson", "failed safe", "errors", "timeouts"]
    head += ["violations", "damage", "p50 s", "p95 s"]
    steps = any(g.steps for g in groups)
    if steps:  # navigators
        head += ["steps p50", "s per m p50"]
    out = [head]
    for g in groups:
        extra = []
        if steps:
            per_m = percentile(g.seconds_per_m, 50)
            extra = [_seconds(percentile(g.steps, 50)), "-" if per_m is None else f"{per_m:.2f}"]
        out.append(
            [
                g.key,
                str(g.n),
                _pct(g.success_rate),
                _interval(g),
                _pct(g.failed_safe_rate),
                str(g.errors),
                str(g.timeouts),
                str(g.violations),
                str(g.damage),
                _seconds(percentile(g.sim_times_s, 50)),
                _seconds(percentile(g.sim_times_s, 95)),
                *extra,
            ]
        )
    return out


def _md_line(text: str) -> str:
    """Text of a row (a run's name, a reason) as one Markdown line: a newline in it
    ended the list item, and the rest was read as a paragraph or a heading."""
    return " ".join(str(text).split())


# What Markdown reads as markup in running text: raw HTML and entities (as entities),
# links and images, code spans, emphasis (backslash-escaped). An '_' between two word
# characters opens no emphasis (bend_3_drive): left as written, so names read as typed.
_MD_HTML = {"&": "&amp;", "<": "&lt;", ">": "&gt;"}
_MD_MARKUP = re.compile(r"[&<>\\`*\[\]]|(?<!\w)_|_(?!\w)")


def _md_text(text: str) -> str:
    """User-given text (a run's name, a reason, a title) as one line of Markdown that
    renders as the text itself: a run named ``<script>...`` was a script element in the
    rendered report.md (report.html escaped it), ``[x](javascript:...)`` a link."""
    return _MD_MARKUP.sub(lambda m: _MD_HTML.get(m.group(), "\\" + m.group()), _md_line(text))


def _md_cell(text: str) -> str:
    """One table cell: a '|' in a run's name (``name: a|b``) split the row's columns."""
    return _md_text(text).replace("|", "\\|")


def _md_code(text: str) -> str:
    """A node's path as inline code, whatever backticks its names hold."""
    line = _md_line(text)
    fence = "`" * (max((len(m) for m in re.findall(r"`+", line)), default=0) + 1)
    pad = " " if line.startswith("`") or line.endswith("`") else ""
    return f"{fence}{pad}{line}{pad}{fence}"


def _top(groups: Sequence[GroupStats], attr: str, n: int = 8) -> list[tuple[str, int]]:
    total: Counter[str] = Counter()
    for g in groups:
        total.update(getattr(g, attr))
    return total.most_common(n)


# A number standing alone ("0.55 s", "seq 17", "40.0°"), not part of a name (bend_3_drive).
_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?![\w.])")


def _top_reasons(groups: Sequence[GroupStats], n: int = 8) -> list[tuple[str, int]]:
    """The most frequent failure reasons, causes that differ only in numbers as one.

    ``stall: bend_3_drive ... for 0.50 s`` and ``... for 0.55 s`` are the same cause:
    they count together and read ``for 0.50–0.55 s``; a number that does not vary is
    shown as written.
    """
    # keyed by the text between the numbers: a '#' of a reason's own ("item # missing")
    # was taken for a number ("item 3 missing") and the report died of a ValueError
    clusters: dict[tuple[str, ...], Counter[str]] = {}
    for g in groups:
        for text, count in g.reasons.items():
            clusters.setdefault(tuple(_NUMBER.split(text)), Counter())[text] += count
    shown: Counter[str] = Counter()
    for texts in clusters.values():
        shown[_merged(list(texts))] += sum(texts.values())
    return shown.most_common(n)


def _merged(texts: list[str]) -> str:
    """One text for texts alike but for their numbers: each varying number as a range."""
    first = texts[0]
    if len(texts) == 1:
        return first
    columns = zip(*(_NUMBER.findall(t) for t in texts), strict=True)
    ranges = []
    for column in columns:
        low, high = min(column, key=float), max(column, key=float)
        ranges.append(low if float(low) == float(high) else f"{low}–{high}")
    parts = iter(ranges)
    return _NUMBER.sub(lambda _: next(parts), first)


def _counters(rows: Sequence[dict[str, Any]]) -> list[list[str]]:
    """Each counter summed over the runs, how many runs counted any, and by kind."""
    out = [["counter", "total", "runs with any", "by kind"]]
    for key, label in _COUNTERS:
        values = [int(r.get(key) or 0) for r in rows]
        kinds: Counter[str] = Counter()
        if key in _KINDS:
            for r in rows:
                kinds.update(r.get(_KINDS[key]) or {})
        by_kind = ", ".join(f"{k} {v}" for k, v in sorted(kinds.items()))
        out.append([label, str(sum(values)), str(sum(v > 0 for v in values)), by_kind])
    return out


def _coverage(rows: Sequence[dict[str, Any]], limit: int = 15) -> list[tuple[str, list[str]]]:
    """Per tree or route, its coverage over every run that recorded one: how many nodes
    ran, which never ran in any run, which guards never failed in any run.

    Returns:
        ``(tree or route, lines)`` pairs, the lines plain text (Markdown-safe).
    """
    from pirate_bt.trace.coverage import GUARDS, Coverage, merge_coverage

    by_tree: dict[str, list[Coverage]] = {}
    for row in rows:
        data = row.get("coverage")
        if not isinstance(data, dict):
            continue
        try:
            coverage = Coverage.from_dict(data)
        except (IndexError, KeyError, TypeError, ValueError):  # a results file edited by hand
            continue
        by_tree.setdefault(str(row.get("tree") or row.get("route") or "?"), []).append(coverage)
    out: list[tuple[str, list[str]]] = []
    for name, items in by_tree.items():
        merged = merge_coverage(items)
        if merged is None:
            continue
        lines = [f"{merged.summary()}."]
        for title, found in (
            ("never ran in any run", merged.never_ran()),
            ("guards and conditions that never failed in any run", merged.never_failed(GUARDS)),
        ):
            shown = [n.path for n in found[:limit]]
            more = [f"... and {len(found) - limit} more"] if len(found) > limit else []
            lines.append(f"{len(found)} {title}" + (":" if found else "."))
            lines += [f"- {text}" for text in [*shown, *more]]
        out.append((name, lines))
    return out


_LABEL = 40
"""The most characters of a run's name in a plot's legend."""


def _plots(rows: Sequence[dict[str, Any]], folder: Path) -> list[Path]:
    """Success rate against each swept link fault rate, one line per run."""
    swept = [k for k in ("drop", "corrupt", "dup") if len({r.get(k) for r in rows}) > 1]
    if not swept:
        return []
    from pirate_bt.render.plot import import_matplotlib

    import_matplotlib().use("Agg")  # whatever MPLBACKEND names
    import matplotlib.pyplot as plt

    from pirate_bt.campaign.stats import success_interval

    runs = sorted({str(r.get("run")) for r in rows})
    # Cut to what a legend shows (a 200-character name overflowed the figure), unless
    # two would then read alike; the table names each whole.
    cut = {run: run if len(run) <= _LABEL else run[: _LABEL - 1] + "…" for run in runs}
    if len(set(cut.values())) < len(cut):
        cut = {run: run for run in runs}
    files: list[Path] = []
    for key in swept:
        fig, ax = plt.subplots(figsize=(6, 4))
        for run in runs:
            mine = [r for r in rows if str(r.get("run")) == run]
            xs = sorted({float(r.get(key) or 0.0) for r in mine})
            rates, lows, highs = [], [], []
            for x in xs:
                at = [r for r in mine if float(r.get(key) or 0.0) == x]
                ok = sum(r.get("outcome") == "success" for r in at)
                low, high = success_interval(at)  # over distinct runs, as the table's
                rates.append(ok / len(at))
                lows.append(low)
                highs.append(high)
            # A run's name is the spec's text: shown as written, never as mathtext
            # (a '$' would make matplotlib parse it, and fail on a stray '\frac').
            label = cut[run].replace("$", r"\$")
            ax.plot([100 * x for x in xs], rates, marker="o", label=label)
            ax.fill_between([100 * x for x in xs], lows, highs, alpha=0.2)
        ax.set_xlabel(f"{key} rate (%)")
        ax.set_ylabel("success rate (95 % Wilson band)")
        ax.set_ylim(0, 1.02)
        ax.grid(True, alpha=0.3)
        ax.legend()
        with warnings.catch_warnings():
            # a legend larger than the figure (many runs) leaves the layout as it was:
            # matplotlib's UserWarning went to standard error, two lines with a path
            warnings.simplefilter("ignore", UserWarning)
            fig.tight_layout()
        target = folder / f"success_vs_{key}.png"
        tmp = folder / f".success_vs_{key}.part.png"
        try:
            fig.savefig(tmp, dpi=100)
            os.replace(tmp, target)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise _unwritable(target, exc) from None
        finally:
            plt.close(fig)
        files.append(target)
    return files


def write_report(
    rows: Sequence[dict[str, Any]], folder: Path, title: str = "campaign", command: str = ""
) -> list[Path]:
    """Write ``report.md``, ``report.html``, ``results.csv`` and the plots into ``folder``.

    Args:
        rows: The campaign's rows.
        folder: Where to write.
        title: The report's title.
        command: The command that reproduces the campaign (shown in the report).

    Returns:
        The files written.
    """
    folder.mkdir(parents=True, exist_ok=True)
    ordered = sorted(rows, key=lambda r: int(r.get("index", 0)))
    groups = group_stats(ordered)
    files = [_replace(folder / "results.csv", _csv(ordered))]
    plots = _plots(ordered, folder)
    table = _table(groups)
    counters = _counters(ordered)
    counts = Counter(str(r.get("outcome")) for r in ordered)
    summary = ", ".join(f"{counts[k]} {k}" for k in ("success", "failed-safe", "error", "timeout"))
    md = [f"# {_md_text(title)}", "", f"{len(ordered)} runs: {summary}.", ""]
    if command:
        md += ["Reproduce with:", "", f"    {command}", ""]
    md += ["| " + " | ".join(table[0]) + " |", "|" + "---|" * len(table[0])]
    md += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in table[1:]]
    reasons, nodes = _top_reasons(groups), _top(groups, "nodes")
    md += ["", "## Most frequent failure reasons", ""]
    md += [f"- {n} × {_md_text(text)}" for text, n in reasons] or ["- none"]
    md += ["", "## Most frequent failing nodes", ""]
    md += [f"- {n} × {_md_code(text)}" for text, n in nodes] or ["- none"]
    md += ["", "## Counters over all runs", ""]
    md += ["| " + " | ".join(row) + " |" for row in counters[:1]]
    md += ["|---|---|---|---|"]
    md += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in counters[1:]]
    # a crashed case has no counters: "violations 0" did not say they were unknown
    unknown = sum(r.get("violations") is None for r in ordered)
    untold = (
        f"{unknown} of {len(ordered)} runs ended without a result of their own (a crash, a"
        " hang, an exception outside the run): their counters are unknown and not in these"
        " totals, violations and damage included."
    )
    md += ["", untold] if unknown else []
    coverage = _coverage(ordered)
    if coverage:
        md += ["", "## Coverage over all runs", ""]
        md += ["Per node, as BehaviorTree.CPP's TreeObserver counts it (`Coverage`)."]
        for name, lines in coverage:
            md += ["", f"### {_md_text(name)}", ""]
            md += [
                f"- {_md_text(line[2:])}" if line.startswith("- ") else f"{_md_text(line)}\n"
                for line in lines
            ]
    if plots:
        md += ["", "## Plots", ""] + [f"![{p.stem}]({p.name})" for p in plots]
    files.append(_replace(folder / "report.md", "\n".join(md) + "\n"))
    esc = html.escape
    cells = "".join(f"<th>{esc(c)}</th>" for c in table[0])
    body = [f"<h1>{esc(title)}</h1>", f"<p>{len(ordered)} runs: {esc(summary)}.</p>"]
    if command:
        body.append(f"<p>Reproduce with: <code>{esc(command)}</code></p>")
    body.append(f"<table><tr>{cells}</tr>")
    for row in table[1:]:
        body.append("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in row) + "</tr>")
    body.append("</table><h2>Most frequent failure reasons</h2><ul>")
    body += [f"<li>{n} × {esc(t)}</li>" for t, n in reasons] or ["<li>none</li>"]
    body.append("</ul><h2>Most frequent failing nodes</h2><ul>")
    body += [f"<li>{n} × <code>{esc(t)}</code></li>" for t, n in nodes] or ["<li>none</li>"]
    body.append("</ul><h2>Counters over all runs</h2><table>")
    body.append("<tr>" + "".join(f"<th>{esc(c)}</th>" for c in counters[0]) + "</tr>")
    for row in counters[1:]:
        body.append("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in row) + "</tr>")
    body.append("</table>")
    body += [f"<p>{esc(untold)}</p>"] if unknown else []
    if coverage:
        body.append("<h2>Coverage over all runs</h2>")
        for name, lines in coverage:
            body.append(f"<h3>{esc(name)}</h3>")
            items: list[str] = []
            for line in lines:
                if line.startswith("- "):
                    items.append(f"<li><code>{esc(line[2:])}</code></li>")
                    continue
                if items:
                    body += ["<ul>", *items, "</ul>"]
                    items = []
                body.append(f"<p>{esc(line)}</p>")
            if items:
                body += ["<ul>", *items, "</ul>"]
    body += [f'<h2>{esc(p.stem)}</h2><img src="{esc(p.name)}">' for p in plots]
    style = (
        "body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
        "td:first-child{text-align:left}"
    )
    page = (
        f"<!doctype html><html><head><meta charset='utf-8'><title>{esc(title)}</title>"
        f"<style>{style}</style></head><body>{''.join(body)}</body></html>\n"
    )
    files.append(_replace(folder / "report.html", page))
    return [*files, *plots]

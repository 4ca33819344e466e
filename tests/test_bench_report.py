"""`make bench`'s publishing: benchmarks' tables rewritten into docs/performance.md.

`benchmarks/report.py` puts each published table between its markers and touches
nothing else; `benchmarks/run_all.py` writes nothing when a benchmark fails. No
benchmark runs here: the benchmarks below are three-line scripts.
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from bench_support import BENCHMARKS, load_benchmark

REPO = Path(__file__).resolve().parent.parent


report = load_benchmark("report")
run_all = load_benchmark("run_all")

DOC = (
    "# Performance\n"
    "\n"
    "Prose with trailing spaces   \n"
    "and unicode: ≤ 15 %, µs, →.\n"
    "\n"
    "<!-- bench:speed -->\n"
    "\n"
    "| old | table |\n"
    "|---|---|\n"
    "| 1 | 2 |\n"
    "\n"
    "<!-- /bench:speed -->\n"
    "\n"
    "Between the blocks.\n"
    "\n"
    "<!-- bench:size -->\n"
    "| size | old |\n"
    "<!-- /bench:size -->\n"
    "Tail with no newline at the end"
)


def _result(name: str = "speed", **kw: object) -> object:
    fields: dict[str, object] = {
        "name": name,
        "header": ("figure", "value"),
        "rows": (("speed-up", "**144x**"),),
        "note": "Median of 3 runs.",
        "source": "bench_speed.py",
        "command": ".venv/bin/python benchmarks/bench_speed.py 3",
        "date": "2026-11-30T12:00:00",
        "commit": "abc1234+dirty",
        "machine": {"cores": 2, "cpu": "AMD EPYC", "python": "3.11.7", "platform": "Linux"},
    }
    fields.update(kw)
    return report.Result(**fields)


def _write(path: Path, text: str) -> Path:
    path.write_bytes(text.encode("utf-8"))
    return path


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(BENCHMARKS / "report.py"), *args],
        capture_output=True,
        text=True,
        check=False,
    )


def test_a_rewrite_leaves_every_byte_outside_the_markers_as_it_was(tmp_path: Path) -> None:
    doc = _write(tmp_path / "performance.md", DOC)
    outcome = report.rewrite(doc, {"speed": _result()})
    new = doc.read_bytes().decode("utf-8")
    assert outcome.written == ["speed"] and outcome.kept == ["size"]
    opening, closing = "<!-- bench:speed -->\n", "<!-- /bench:speed -->"
    before, after = DOC.split(opening)[0], DOC.split(closing)[1]
    assert new.startswith(before + opening)
    assert new.endswith(closing + after)
    block = new[len(before + opening) : -len(closing + after)]
    assert "| speed-up | **144x** |" in block
    assert "Median of 3 runs." in block
    assert "| old | table |" not in new


def test_line_endings_of_a_crlf_document_are_kept(tmp_path: Path) -> None:
    doc = _write(tmp_path / "performance.md", DOC.replace("\n", "\r\n"))
    report.rewrite(doc, {"speed": _result()})
    data = doc.read_bytes()
    assert b"| speed-up | **144x** |\r\n" in data
    assert data.count(b"\n") == data.count(b"\r\n")


def test_the_header_line_names_date_commit_machine_and_command(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(sys, "argv", ["benchmarks/bench_speed.py", "3"])
    monkeypatch.chdir(REPO)
    results = tmp_path / "results"
    path = report.publish("speed", ["figure", "value"], [["speed-up", "144x"]], results=results)
    assert path == results / "speed.json"
    assert "| speed-up | 144x |" in capsys.readouterr().out
    doc = _write(tmp_path / "performance.md", DOC)
    report.rewrite(doc, results)
    header = next(line for line in doc.read_text("utf-8").splitlines() if "Measured on" in line)
    assert datetime.date.today().isoformat() in header
    head = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    assert f"commit {head}" in header
    assert f"{os.cpu_count()} cores" in header
    assert f"Python {platform.python_version()}" in header
    assert platform.system() in header
    assert "benchmarks/bench_speed.py 3`" in header
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        models = [ln for ln in cpuinfo.read_text().splitlines() if ln.startswith("model name")]
        if models:
            model = " ".join(models[0].split(":", 1)[1].split())
            assert model.replace("_", r"\_").replace("*", r"\*") in header


def test_a_dirty_tree_is_marked_dirty(tmp_path: Path) -> None:
    def git(*args: str) -> None:
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    git("init", "-q")
    (tmp_path / "f").write_text("a")
    git("add", "f")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "one")
    clean = report.git_commit(tmp_path)
    (tmp_path / "f").write_text("b")
    assert "+" not in clean
    assert report.git_commit(tmp_path) == clean + "+dirty"


def test_a_block_without_a_fresh_result_keeps_its_table_and_says_so(tmp_path: Path) -> None:
    doc = _write(tmp_path / "performance.md", DOC)
    results = tmp_path / "results"
    report.publish("speed", ["figure", "value"], [["speed-up", "144x"]], results=results)
    done = _cli("--write", str(doc), str(results))
    assert done.returncode == 0, done.stderr
    assert "bench:size kept as it was (no fresh result)" in done.stdout
    assert "<!-- bench:size -->\n| size | old |\n<!-- /bench:size -->" in doc.read_text("utf-8")


def test_a_result_without_a_marker_is_a_one_line_warning_naming_it(tmp_path: Path) -> None:
    doc = _write(tmp_path / "performance.md", DOC)
    results = tmp_path / "results"
    report.publish("speed", ["figure", "value"], [["speed-up", "144x"]], results=results)
    report.publish("ghost", ["figure"], [["1"]], results=results)
    done = _cli("--write", str(doc), str(results))
    assert done.returncode == 0
    warnings = [line for line in done.stderr.splitlines() if "ghost" in line]
    assert len(warnings) == 1
    assert warnings[0].startswith("warning: result 'ghost'")
    assert "<!-- bench:ghost -->" in warnings[0]
    assert "| speed-up | 144x |" in doc.read_text("utf-8")  # the others are written


BAD = [
    ("nested", "<!-- bench:a -->\n<!-- bench:b -->\n<!-- /bench:b -->\n<!-- /bench:a -->\n", 2),
    ("closes nothing", "text\n\n<!-- /bench:a -->\n", 3),
    ("never closed", "x\n<!-- bench:a -->\nthe rest of the page\n", 2),
    ("other name", "x\n<!-- bench:a -->\n<!-- /bench:b -->\n", 3),
    ("twice", "<!-- bench:a -->\n<!-- /bench:a -->\n\n<!-- bench:a -->\n<!-- /bench:a -->\n", 4),
]
GOOD = "<!-- bench:speed -->\n<!-- /bench:speed -->\n\n"
"""A block with a fresh result, ahead of the bad markers (3 lines)."""


@pytest.mark.parametrize(("markers", "line"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_markers_that_do_not_pair_up_are_a_one_line_error_and_nothing_is_written(
    tmp_path: Path, markers: str, line: int
) -> None:
    text = GOOD + markers
    doc = _write(tmp_path / "performance.md", text)
    before = doc.stat()
    results = tmp_path / "results"
    report.publish("speed", ["figure", "value"], [["speed-up", "144x"]], results=results)
    done = _cli("--write", str(doc), str(results))
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1
    assert f"performance.md:{line + 3}:" in done.stderr
    assert "not written" in done.stderr
    assert doc.read_bytes() == text.encode("utf-8")
    assert doc.stat().st_mtime_ns == before.st_mtime_ns
    assert sorted(p.name for p in tmp_path.iterdir()) == ["performance.md", "results"]


def test_markers_inside_a_code_fence_are_text(tmp_path: Path) -> None:
    text = "```md\n<!-- bench:speed -->\n```\n\n<!-- bench:speed -->\nold\n<!-- /bench:speed -->\n"
    doc = _write(tmp_path / "performance.md", text)
    report.rewrite(doc, {"speed": _result()})
    new = doc.read_text("utf-8")
    assert new.startswith("```md\n<!-- bench:speed -->\n```\n")
    assert "old" not in new and "**144x**" in new


def test_the_document_is_written_whole_or_not_at_all(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    doc = _write(tmp_path / "performance.md", DOC)
    doc.chmod(0o640)
    moves: list[tuple[str, str]] = []
    real_replace = os.replace

    def failing_replace(src: str, dst: str) -> None:
        moves.append((src, dst))
        raise OSError("disk full")

    monkeypatch.setattr(report.os, "replace", failing_replace)
    with pytest.raises(OSError, match="disk full"):
        report.rewrite(doc, {"speed": _result()})
    assert doc.read_bytes() == DOC.encode("utf-8")
    assert [p.name for p in tmp_path.iterdir()] == ["performance.md"]  # no temporary left
    # The new text went to a file beside the document, to be moved over it in one step.
    ((src, dst),) = moves
    assert Path(src).parent == tmp_path and Path(dst) == doc

    monkeypatch.setattr(report.os, "replace", real_replace)
    report.rewrite(doc, {"speed": _result()})
    assert "**144x**" in doc.read_text("utf-8")
    assert doc.stat().st_mode & 0o777 == 0o640
    assert [p.name for p in tmp_path.iterdir()] == ["performance.md"]


def test_publish_without_a_results_directory_only_prints(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv(report.RESULTS_ENV, raising=False)
    monkeypatch.chdir(tmp_path)
    assert report.publish("speed", ["a", "b"], [["x|y", 2]], note="A note.") is None
    out = capsys.readouterr().out
    assert "| a | b |\n|---|---|\n| x\\|y | 2 |" in out and "A note." in out
    assert list(tmp_path.iterdir()) == []


def test_publish_refuses_a_row_that_does_not_fit_the_header() -> None:
    with pytest.raises(ValueError, match="2 cells for 3 columns"):
        report.publish("speed", ["a", "b", "c"], [["1", "2"]], results=None)
    with pytest.raises(ValueError, match="bad result name"):
        report.publish("Speed Table", ["a"], [["1"]])


def _bench(folder: Path, name: str, body: str) -> Path:
    script = folder / f"bench_{name}.py"
    script.write_text(
        f"import sys\nsys.path.insert(0, {str(BENCHMARKS)!r})\nfrom report import publish\n"
        + textwrap.dedent(body),
        encoding="utf-8",
    )
    return script


def test_make_bench_writes_nothing_when_a_benchmark_fails(tmp_path: Path) -> None:
    doc = _write(tmp_path / "performance.md", DOC)
    good = _bench(tmp_path, "speed", "publish('speed', ['figure'], [['fresh']])\n")
    bad = _bench(tmp_path, "size", "publish('size', ['figure'], [['fresh']])\nsys.exit(3)\n")
    results = tmp_path / "results"
    results.mkdir()
    assert run_all.run([(good, []), (bad, [])], results, doc, cwd=tmp_path) == 1
    assert doc.read_bytes() == DOC.encode("utf-8")


def test_make_bench_rewrites_the_tables_of_the_benchmarks_that_ran(tmp_path: Path) -> None:
    doc = _write(tmp_path / "performance.md", DOC)
    good = _bench(tmp_path, "speed", "publish('speed', ['figure'], [[' '.join(sys.argv[1:])]])\n")
    results = tmp_path / "results"
    results.mkdir()
    steps = run_all.plan([good], overrides={"speed": ["--runs", "2"]})
    assert run_all.run(steps, results, doc, cwd=tmp_path) == 0
    text = doc.read_text("utf-8")
    assert "| --runs 2 |" in text
    assert "bench_speed.py --runs 2`" in text  # the command in the header line
    assert "<!-- bench:size -->\n| size | old |\n<!-- /bench:size -->" in text


def test_make_bench_gives_the_long_benchmarks_quick_counts_unless_full() -> None:
    every = run_all.scripts()
    quick = dict((s.name, a) for s, a in run_all.plan(every))
    full = dict((s.name, a) for s, a in run_all.plan(every, full=True))
    for name in ("bench_asbuilt.py", "bench_survey.py", "bench_navigators.py"):
        assert quick[name], name
        assert full[name] == []


def test_the_performance_page_has_well_formed_markers() -> None:
    lines = (REPO / "docs" / "performance.md").read_text("utf-8").splitlines(keepends=True)
    blocks = report.find_blocks(lines, "docs/performance.md")
    for name in ("mission", "trace", "interop-overhead", "trees", "campaign-case", "link"):
        assert name in blocks

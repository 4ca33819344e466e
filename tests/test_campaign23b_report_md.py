"""Session 23: ``report.md`` shows user-given text as text, never as HTML.

``report.html`` escaped every run name, reason and title; ``report.md`` wrote them as
they were, so a run named ``<script>alert(1)</script>`` was a script element wherever
the Markdown was rendered (a repository's page, a wiki, ``mkdocs``), and a name such
as ``[x](javascript:alert(1))`` a link. Every user-given text written to report.md is
now escaped where Markdown would read it as HTML (``<``, ``>``, ``&``) or as a link,
image, emphasis or code; node paths stay in code spans, which Markdown shows as written.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.campaign.report import write_report

HOSTILE = "<script>alert(1)</script> [x](javascript:alert(2)) *b* &amp;"
REASON = "stall: <img src=x onerror=alert(3)> at bend_3_drive"


def _rows() -> list[dict[str, object]]:
    return [
        {"id": f"{i:06d}-a", "index": i, "run": HOSTILE, "drop": 0.0, "corrupt": 0.0,
         "dup": 0.0, "seed": i, "outcome": "failed-safe", "reason": REASON,
         "failing_node": "root/<b>x</b>", "violations": 0, "damage": 0}
        for i in range(2)
    ]  # fmt: skip


def test_report_md_escapes_html_and_links_in_names_reasons_and_title(tmp_path: Path) -> None:
    write_report(_rows(), tmp_path, title="<h1>t</h1>")
    md = (tmp_path / "report.md").read_text(encoding="utf-8")
    for raw in ("<script>", "<img", "<h1>t", "[x](javascript", "*b*", " &amp; "):
        assert raw not in md.split("## Most frequent failing nodes")[0], raw
    assert "# &lt;h1&gt;t&lt;/h1&gt;\n" in md
    assert "&lt;script&gt;alert(1)&lt;/script&gt; \\[x\\](javascript:alert(2))" in md
    assert "- 2 × stall: &lt;img src=x onerror=alert(3)&gt; at bend_3_drive" in md
    # a node's path is inline code: shown as written, no HTML either way
    assert "- 2 × `root/<b>x</b>`" in md


def test_report_md_renders_each_text_as_the_text_it_was(tmp_path: Path) -> None:
    markdown = pytest.importorskip("markdown")
    write_report(_rows(), tmp_path, title="<h1>t</h1>")
    html = markdown.markdown(
        (tmp_path / "report.md").read_text(encoding="utf-8"), extensions=["tables"]
    )
    assert "<script" not in html and "<img" not in html and "<a " not in html
    assert "<em>" not in html and "<h1>t" not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html

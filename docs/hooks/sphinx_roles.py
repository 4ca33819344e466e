"""MkDocs hook: show the docstrings' Sphinx markup as plain Markdown would.

The library's docstrings are Google style with Sphinx cross-reference roles
(``:func:`simulate_tree```, ``:class:`~pirate_bt.trace.Trace```) and reST literal
blocks introduced by ``::`` (``Example::``), which read well in ``help()`` and
IDEs. mkdocstrings renders them as Markdown, where a role would show as
``:func:simulate_tree``; this hook turns a role into its code text (``~``: the
last name only) and ends a paragraph before a literal block with one colon.
"""

from __future__ import annotations

import re
from typing import Any

_ROLE = re.compile(
    r":(?:py:)?(?:func|class|meth|mod|attr|data|exc|obj|const|paramref):<code>(~?)([^<]*)</code>"
)
_LITERAL_INTRO = re.compile(r"::</p>")


def _role(match: re.Match[str]) -> str:
    tilde, target = match.groups()
    shown = target.rsplit(".", 1)[-1] if tilde else target
    return f"<code>{shown}</code>"


def on_page_content(html: str, **kwargs: Any) -> str:
    """Rewrite one page's HTML after Markdown, before the theme wraps it."""
    return _LITERAL_INTRO.sub(":</p>", _ROLE.sub(_role, html))

"""No import circle among pirate_bt's modules (DESIGN.md: none forms a circle).

``lint-imports`` (``make lint``) checks the layers and, with its ``acyclic_siblings``
contract, circles between the modules of one package. That contract does not see a
circle through a package's own ``__init__`` (``pirate_bt`` re-exports the API, so a
module that imports ``pirate_bt`` closes a circle through everything the top level
imports). This test looks at the whole module graph, as grimp (import-linter's
graph library) builds it: function-level and ``TYPE_CHECKING`` imports count too.
"""

from __future__ import annotations

import itertools

import grimp


def _circles(graph: grimp.ImportGraph) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    modules = sorted(graph.modules)
    edges = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in modules}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in modules:
        if start in index:
            continue
        work = [(start, 0)]
        while work:
            node, i = work.pop()
            if i == 0:
                index[node] = low[node] = len(index)
                stack.append(node)
                on_stack.add(node)
            if i < len(edges[node]):
                work.append((node, i + 1))
                nxt = edges[node][i]
                if nxt not in index:
                    work.append((nxt, 0))
                elif nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
                continue
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
    return found


def _one_cycle(graph: grimp.ImportGraph, component: list[str]) -> str:
    """A shortest circle through the component's first module, with file lines."""
    first, members = component[0], set(component)
    best: tuple[str, ...] | None = None
    for nxt in sorted(graph.find_modules_directly_imported_by(first) & members):
        chain = graph.find_shortest_chain(importer=nxt, imported=first)
        if chain is not None and (best is None or len(chain) < len(best) - 1):
            best = (first, *chain)
    assert best is not None
    steps = []
    for importer, imported in itertools.pairwise(best):
        lines = graph.get_import_details(importer=importer, imported=imported)
        where = ", ".join(f"l.{d['line_number']}" for d in lines) or "?"
        steps.append(f"  {importer} -> {imported} ({where})")
    return "\n".join(steps)


def test_no_import_circles() -> None:
    graph = grimp.build_graph("pirate_bt", cache_dir=None)
    circles = _circles(graph)
    report = "\n\n".join(
        f"{len(c)} modules in a circle: {', '.join(c)}\nfor example:\n{_one_cycle(graph, c)}"
        for c in circles
    )
    assert not circles, f"import circles in pirate_bt:\n\n{report}"


def test_circle_finder_finds_a_circle() -> None:
    graph = grimp.ImportGraph()
    for name in ("p", "p.a", "p.b", "p.c"):
        graph.add_module(name)
    graph.add_import(importer="p.a", imported="p.b")
    graph.add_import(importer="p.b", imported="p.a")
    graph.add_import(importer="p.c", imported="p.a")
    assert _circles(graph) == [["p.a", "p.b"]]
    assert _one_cycle(graph, ["p.a", "p.b"]) == "  p.a -> p.b (?)\n  p.b -> p.a (?)"

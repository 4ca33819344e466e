"""Pictures of trees and runs: Graphviz diagrams and matplotlib plots.

:func:`tree_graph` builds a diagram's ``dot`` source (optionally coloured by
status at one tick of a trace) and :func:`render_tree` writes it as ``.dot``,
``.svg`` or ``.png``. :func:`plot_trace` draws joints, clamps, speed and
rotation over time from a trace (needs the ``plot`` extra).
"""

from pirate_bt.render.plot import plot_trace
from pirate_bt.render.tree import render_tree, tree_graph, write_diagram

__all__ = ["plot_trace", "render_tree", "tree_graph", "write_diagram"]

"""pirate_bt: behaviour-tree autonomy for the PIRATE pipe-inspection robot.

Light on import: the command line starts in well under 0.3 s because heavy
modules (py_trees, pydantic models, graphviz) are imported where they are used.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]

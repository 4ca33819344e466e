"""Behaviour trees as YAML files: format, registry, static checks, build to py_trees."""

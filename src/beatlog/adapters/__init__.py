"""Adapters between beatlog and other robotics tools.

Each adapter is its own module and imports its tool only when it is imported itself,
so ``import beatlog`` never needs them: :mod:`beatlog.adapters.py_trees` records and
replays a py_trees behaviour tree (``pip install 'beatlog[py_trees]'``).
"""

__all__: list[str] = []

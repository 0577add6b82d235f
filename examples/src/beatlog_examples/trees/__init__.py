"""A patrol rover's py_trees behaviour tree, recorded and replayed through
:mod:`beatlog.adapters.py_trees`, with two DTCs.

- :mod:`~beatlog_examples.trees.patrol`: the tree (a Parallel root, Selectors,
  Sequences, decorators, the blackboard, py_trees' ``Timer`` and ``Timeout``, random
  waypoints) and the system that wraps it.
- :mod:`~beatlog_examples.trees.record`: a toy yard and the scenarios; re-records the
  DTCs in ``suite/`` (``python -m beatlog_examples.trees.record --overwrite``).

Factories for the CLI: ``beatlog_examples.trees:system`` and ``:changed_system``
(the low-battery threshold lowered from 25 % to 20 %). Needs ``beatlog[py-trees]``.
"""

from pathlib import Path

from beatlog_examples.trees.patrol import PatrolState, changed_system, system

__all__ = ["SUITE_DIR", "PatrolState", "changed_system", "system"]

SUITE_DIR = Path(__file__).with_name("suite")
"""The committed DTCs of the patrol tree."""

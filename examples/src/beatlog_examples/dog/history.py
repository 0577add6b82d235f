"""The dog's own history: intended changes a team makes over months, as code edits.

Each :class:`Change` is an edit to the dog's source that a developer makes on purpose:
a random range retuned, a behavior that draws once more, a perception constant, a
threshold, a behavior gone, two behaviors swapped. A DTC suite that lives keeps every
one of them by re-baselining (``beatlog test --update``, then review), with no new
recording, and still catches a bug planted afterwards (:data:`PLANTED_BUG`).
:func:`changed_dog` writes the dog's replay side (behaviors, perception) with some of
them applied as a package of its own, so that each step of the history can be
imported beside the others; ``bench/bench_intended_changes.py`` and the examples' tests replay
the committed suite against it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

__all__ = ["CHANGES", "PLANTED_BUG", "Change", "changed_dog"]

_SOURCES = ("behaviors.py", "perception.py", "rates.py")
"""What replaying the dog needs (the live robot's modules import MuJoCo)."""
_HERE = Path(__file__).parent


class Change(NamedTuple):
    """An edit to one of the dog's modules: ``old`` (found exactly once) becomes ``new``."""

    title: str
    module: str
    old: str
    new: str


CHANGES = (
    Change(
        "a random range retuned",
        "behaviors.py",
        "ctx.random.uniform(0.8, 1.6)",
        "ctx.random.uniform(0.7, 1.5)",
    ),
    Change(
        "a gauss sigma retuned",
        "behaviors.py",
        "ctx.random.gauss(0.0, 3.0)",
        "ctx.random.gauss(0.0, 2.0)",
    ),
    Change(
        "a behavior adds one draw",
        "behaviors.py",
        "self._segment_end = _until(ctx, chance.uniform(2.0, 5.0))",
        "self._segment_end = _until(ctx, chance.uniform(2.0, 5.0) + 0.2 * chance.random())",
    ),
    Change(
        "a perception constant retuned",
        "perception.py",
        "SPEED_SMOOTHING = 0.05",
        "SPEED_SMOOTHING = 0.08",
    ),
    Change(
        "a behavior threshold retuned",
        "behaviors.py",
        "avoid_distance: float = 0.35",
        "avoid_distance: float = 0.4",
    ),
    Change(
        "a behavior removed from the arbiter",
        "behaviors.py",
        "    Chin,\n    HeadPat,",
        "    HeadPat,",
    ),
    Change(
        "two behaviors swapped in priority",
        "behaviors.py",
        "    Avoid,\n    WallFollow,",
        "    WallFollow,\n    Avoid,",
    ),
)
"""Intended changes, in the order a team might make them."""

PLANTED_BUG = Change(
    "a bug: escape backs off slower",
    "behaviors.py",
    "return _walk(-0.12, 0.0)",
    "return _walk(-0.10, 0.0)",
)
"""An unintended change that the suite must catch once the intended ones are kept."""


def changed_dog(folder: Path, name: str, changes: Sequence[Change]) -> str:
    """Write the dog's behaviors and perception with ``changes`` applied, as the package
    ``name`` in ``folder`` (put ``folder`` on ``sys.path`` to import it); its system
    reference (``NAME:system``; the perception is ``NAME.perception:perception``).

    :raises ValueError: a change's text is not found exactly once.
    """
    package = folder / name
    package.mkdir(parents=True)
    for module in _SOURCES:
        source = (_HERE / module).read_text(encoding="utf-8")
        for change in changes:
            if change.module == module:
                if source.count(change.old) != 1:
                    raise ValueError(f"{change.title}: {change.old!r} is not in {module} once")
                source = source.replace(change.old, change.new)
        source = source.replace("beatlog_examples.dog.", f"{name}.")
        (package / module).write_text(source, encoding="utf-8")
    (package / "__init__.py").write_text(
        f"from {name}.behaviors import system\n\n__all__ = ['system']\n", encoding="utf-8"
    )
    return f"{name}:system"

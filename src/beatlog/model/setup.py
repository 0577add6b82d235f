"""Draws at set-up: code that randomises once, when its objects are built (a driver's
desired speed picked in ``__init__``), draws from the random source its system's
factory is handed.

A system factory that takes a keyword parameter ``random`` is called with the session's
:class:`~beatlog.model.source.RandomSource`. Recording keeps what it draws in the log's
header; replay hands the factory a source that serves them back and checks them as it
does a cycle's (:mod:`beatlog.replay.setup`).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from beatlog.model.behavior import System
from beatlog.model.source import RandomSource

__all__ = ["SystemFactory", "build_system", "takes_random"]

SystemFactory = Callable[..., System]
"""What builds a system: called with ``random=`` the session's random source where it
takes that keyword (:func:`takes_random`), else with no argument."""

_BY_KEYWORD = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)


def takes_random(factory: Callable[..., Any]) -> bool:
    """Whether ``factory`` takes the random source: it has a parameter ``random`` that
    can be passed by keyword."""
    try:
        parameters = inspect.signature(factory).parameters
    except (TypeError, ValueError):  # a builtin without a signature takes none
        return False
    found = parameters.get("random")
    return found is not None and found.kind in _BY_KEYWORD


def build_system(factory: SystemFactory, random: RandomSource) -> System:
    """What ``factory`` builds, handed ``random`` to draw from where it takes it."""
    return factory(random=random) if takes_random(factory) else factory()

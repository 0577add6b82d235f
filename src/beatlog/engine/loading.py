"""Import a system or robot from a ``module:factory`` reference given by the user.

Only references a user types are imported; a log's recorded reference is shown to
people but never imported, so loading a log cannot run code.
"""

from __future__ import annotations

import importlib
from typing import Any

from beatlog.errors import SystemLoadError
from beatlog.model.behavior import System

__all__ = ["load_factory", "load_system"]


def load_factory(reference: str) -> Any:
    """Import ``module:attribute`` and return the attribute called (if callable)."""
    module_name, sep, attribute = reference.partition(":")
    if not sep or not module_name or not attribute:
        raise SystemLoadError(f"{reference!r}: expected module:factory, e.g. mypkg.robot:system")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise SystemLoadError(f"{reference!r}: cannot import {module_name}: {exc}") from None
    factory = module
    for part in attribute.split("."):
        try:
            factory = getattr(factory, part)
        except AttributeError:
            raise SystemLoadError(f"{reference!r}: {module_name} has no {attribute}") from None
    if not callable(factory):
        return factory
    try:
        return factory()
    except Exception as exc:
        raise SystemLoadError(
            f"{reference!r}: the factory raised {type(exc).__name__}: {exc}"
        ) from None


def load_system(reference: str) -> System:
    """Build the system a ``module:factory`` reference names, checking it is one."""
    system = load_factory(reference)
    if not isinstance(system, System):
        raise SystemLoadError(
            f"{reference!r}: built a {type(system).__name__}, not a system "
            "(it needs robot_state, behaviors and update)"
        )
    return system

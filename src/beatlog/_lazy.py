"""Public names that a package imports when they are first used, so that importing the
package costs next to nothing (``import beatlog`` pulls in neither numpy nor rich)."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(package: str, modules: Mapping[str, str]) -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package``: each name of ``modules`` (name → the
    module that defines it) is imported when first asked for and kept in the package."""
    namespace = vars(sys.modules[package])

    def lookup(name: str) -> Any:
        module = modules.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    return lookup

"""Public names that a package imports when they are first used, so that importing the
package costs next to nothing (``import beatlog`` pulls in neither numpy nor rich).

A package lists each public name once, in its ``if TYPE_CHECKING:`` block, as
``from module import Name as Name``, read by type checkers, the documentation and,
at run time, :func:`lazy_names`.
"""

from __future__ import annotations

import functools
import importlib
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(package: str) -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package``: each name its ``if TYPE_CHECKING:``
    block imports is imported when first asked for and kept in the package; its
    ``__all__`` is those names, in the block's order."""
    namespace = vars(sys.modules[package])

    def lookup(name: str) -> Any:
        modules = exported(namespace["__file__"])
        if name == "__all__":
            value: Any = list(modules)
        elif name in modules:
            value = getattr(importlib.import_module(modules[name]), name)
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        namespace[name] = value
        return value

    return lookup


@functools.cache
def exported(init: str) -> dict[str, str]:
    """The names the ``if TYPE_CHECKING:`` block of the package ``__init__`` at ``init``
    imports, each with the module it comes from (read when a name is first asked for:
    the package's import stays light)."""
    import ast  # noqa: PLC0415 - only once a name is asked for

    with open(init, encoding="utf-8") as source:
        tree = ast.parse(source.read(), init)
    return {
        alias.asname or alias.name: node.module
        for block in tree.body
        if isinstance(block, ast.If) and ast.unparse(block.test) == "TYPE_CHECKING"
        for node in block.body
        if isinstance(node, ast.ImportFrom) and node.module is not None
        for alias in node.names
    }

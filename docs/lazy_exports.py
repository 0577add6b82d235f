"""A griffe extension for the API reference: a lazy package ``__init__``
(:mod:`beatlog.log._lazy`) lists its public names once, as the imports of its
``if TYPE_CHECKING:`` block; this makes them its exports, as ``__all__`` would."""

from __future__ import annotations

from typing import Any

import griffe


class LazyExports(griffe.Extension):
    """Exports, for every module without ``__all__``, the names it imports only for type
    checkers (what a lazy package hands out on first use)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        for module in _modules(pkg):
            if module.exports is None:
                typed = [
                    name
                    for name, member in module.members.items()
                    if member.is_alias and not member.runtime
                ]
                if typed:
                    module.exports = typed


def _modules(module: griffe.Module) -> list[griffe.Module]:
    """The module and its submodules, all the way down."""
    found = [module]
    for member in module.members.values():
        if not member.is_alias and isinstance(member, griffe.Module):
            found.extend(_modules(member))
    return found

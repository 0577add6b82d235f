"""A griffe extension for the API reference: beatlog's docstrings use Sphinx roles
(:class:`X`, :meth:`Y.z`); this turns each into a link to the object where the
reference documents it, and into plain code where it does not."""

from __future__ import annotations

import re
from functools import partial
from typing import Any

import griffe

_ROLE = re.compile(r":(?:class|meth|func|attr|mod|data|exc):`(?P<target>[^`]+)`")


class SphinxRoles(griffe.Extension):
    """Rewrites the Sphinx roles in every docstring of a package once it is loaded."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        for obj in _objects(pkg):
            if obj.docstring is not None:
                obj.docstring.value = _ROLE.sub(partial(_link, obj), obj.docstring.value)


def _objects(obj: griffe.Object) -> list[griffe.Object]:
    """The object and everything defined in it (not what it imports)."""
    found = [obj]
    for member in obj.members.values():
        if isinstance(member, griffe.Object):
            found.extend(_objects(member))
    return found


def _link(obj: griffe.Object, role: re.Match[str]) -> str:
    """An optional cross-reference: a link when its target is documented, code otherwise."""
    target = role["target"]
    short = target.startswith("~")
    name = target.removeprefix("~")
    title = name.rsplit(".", 1)[-1] if short else name.lstrip(".")
    try:
        path = _resolve(obj, name)
    except griffe.NameResolutionError:
        return f"`{title}`"
    return f'<autoref identifier="{path}" optional><code>{title}</code></autoref>'


def _resolve(obj: griffe.Object, name: str) -> str:
    if name.startswith("."):
        module = obj.module
        package = module if module.is_init_module else module.parent
        assert package is not None
        return package.path + name
    if name.startswith(f"{obj.package.path}."):
        return name
    first, _, rest = name.partition(".")
    resolved = obj.resolve(first)
    return f"{resolved}.{rest}" if rest else resolved

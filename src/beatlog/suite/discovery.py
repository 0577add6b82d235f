"""Finding DTC specs: every spec file under the folders given, each loaded once with
its id from the rootdir pytest would take, and the specs a ``-k`` expression and tags
select, as pytest selects their items."""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Iterable, Sequence
from pathlib import Path

from beatlog.errors import SpecError
from beatlog.suite.keywords import KeywordExpression
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, find_rootdir, load_spec

__all__ = ["discover_specs", "distinguished", "select_specs"]


def discover_specs(paths: Iterable[str | Path], *, rootdir: Path | None = None) -> list[DtcSpec]:
    """Every spec in the given files and folders (recursively), sorted by path, with ids
    from ``rootdir`` (by default, the one :func:`find_rootdir` finds for ``paths``).
    Specs may share a name; a spec file holds one DTC and is loaded once, so no two have
    one id."""
    paths = list(paths)
    found: list[Path] = []
    for given in map(Path, paths):
        if given.is_dir():
            found.extend(
                path
                for path in given.rglob(f"*{SPEC_SUFFIX}")
                if path.is_file() and not _hidden(path.relative_to(given))
            )
        elif given.name.endswith(SPEC_SUFFIX):
            found.append(given)
        elif not given.exists():
            raise SpecError(given, "no such file or folder")
        else:
            raise SpecError(given, f"not a DTC spec (expected a *{SPEC_SUFFIX} file)")
    # One spec named twice (``specs`` and ``/abs/specs/a.dtc.toml``) is loaded once.
    unique: dict[Path, Path] = {}
    for path in found:
        unique.setdefault(path.resolve(), path)
    root = find_rootdir(paths) if rootdir is None else rootdir
    return [load_spec(path, rootdir=root) for path in sorted(unique.values())]


def distinguished(specs: Iterable[DtcSpec]) -> list[DtcSpec]:
    """The specs of a run, those that share their name with another named by their id
    in reports (:attr:`DtcSpec.label`)."""
    specs = list(specs)
    counts = Counter(spec.name for spec in specs)
    return [dataclasses.replace(spec, named_by_id=counts[spec.name] > 1) for spec in specs]


def _hidden(relative: Path) -> bool:
    """Whether a path found under a folder lies in a hidden folder (.git, .venv, ...)."""
    return any(part.startswith(".") for part in relative.parts[:-1])


def select_specs(
    specs: Sequence[DtcSpec],
    *,
    pattern: str | None = None,
    tags: Sequence[str] = (),
    rootdir: Path | None = None,
) -> list[DtcSpec]:
    """Specs that match ``pattern`` and carry every tag in ``tags``.

    ``pattern`` is a ``-k`` expression as pytest reads it (``touch or pat``): each word
    a case-insensitive substring of one of the names pytest matches for the DTC: its
    name, its spec file's name, the folders from ``rootdir`` down to it, its tags, and
    the ``dtc`` marker (see :mod:`beatlog.suite.keywords`). ``rootdir`` is the folder
    pytest would take for its rootdir (by default, as :func:`find_rootdir` finds it for the
    specs' own folders).
    """
    expression = KeywordExpression.parse(pattern or "")
    root = rootdir if rootdir is not None else find_rootdir(spec.path for spec in specs)
    return [
        spec
        for spec in specs
        if expression.matches(_keywords(spec, root)) and set(tags) <= set(spec.tags)
    ]


def _keywords(spec: DtcSpec, root: Path) -> list[str]:
    """The names pytest's ``-k`` matches for a DTC item: its own, its file's, its
    folders below the rootdir (the rootdir itself left out, as pytest leaves it out),
    its tags and its marker."""
    path = spec.path.resolve()
    folders = path.parent.relative_to(root).parts if path.is_relative_to(root) else ()
    return [spec.name, path.name, *folders, *spec.tags, "dtc"]

"""Finding DTC specs: every spec file under the folders given, each loaded once with
its id from the rootdir pytest would take, and the specs a ``-k`` expression and tags
select, as pytest selects their items.

A ``-k`` word matches a DTC when it is a case-insensitive substring of one of the names
pytest gives its item: the DTC's name, its spec file's name, the folders between the
rootdir and the spec, its tags and the ``dtc`` marker; so ``beatlog test -k EXPR``
selects the DTCs that ``pytest -k EXPR`` runs. pytest's matcher is private and beatlog
does not depend on pytest, so :class:`KeywordExpression` parses the same grammar::

    expression := term ("or" term)*
    term       := factor ("and" factor)*
    factor     := "not" factor | "(" expression ")" | word
"""

from __future__ import annotations

import dataclasses
import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

from beatlog.errors import OptionError, SpecError
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, find_rootdir, load_spec, read_spec_data

__all__ = [
    "KeywordExpression",
    "discover_specs",
    "distinguished",
    "files_under",
    "no_specs_found",
    "select_specs",
]


def discover_specs(paths: Iterable[str | Path], *, rootdir: Path | None = None) -> list[DtcSpec]:
    """Every spec in the given files and folders (recursively, hidden folders such as
    ``.git`` left out), each loaded once, sorted by path, with ids from ``rootdir`` (by
    default, the one :func:`find_rootdir` finds for ``paths``)."""
    paths = list(paths)
    found: list[Path] = []
    for given in map(Path, paths):
        if given.is_dir():
            found.extend(files_under(given, SPEC_SUFFIX))
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


def no_specs_found(paths: Sequence[Path]) -> str:
    """That ``paths`` hold no spec, with what they hold instead that a newcomer meant as
    one: a spec named ``*.toml`` without ``.dtc``, or a log with no spec beside it."""
    folders = [path for path in paths if path.is_dir()]
    misnamed = sorted(
        path for folder in folders for path in files_under(folder, ".toml") if _names_a_log(path)
    )
    logs = sorted(path for folder in folders for path in files_under(folder, ".beatlog"))
    found = (
        f"; {misnamed[0]} is not one, a spec's name ends in {SPEC_SUFFIX}"
        if misnamed
        else f"; {logs[0]} has none: a NAME{SPEC_SUFFIX} beside it makes it a DTC, see "
        "beatlog help spec"
        if logs
        else ""
    )
    where = " ".join(map(str, paths))
    return f"no DTC specs to run in {where} (looked for *{SPEC_SUFFIX}{found})"


def _names_a_log(toml: Path) -> bool:
    """Whether a TOML file reads as a spec's data (a small regular file) with its
    ``log`` key."""
    try:
        return "log" in read_spec_data(toml)
    except (SpecError, OSError):
        return False


def files_under(folder: Path, suffix: str) -> list[Path]:
    """The files under ``folder`` whose names end in ``suffix``, those in hidden folders
    (``.git``, ``.venv``) left out."""
    return [
        path
        for path in folder.rglob(f"*{suffix}")
        if path.is_file()
        and not any(part.startswith(".") for part in path.relative_to(folder).parts[:-1])
    ]


def distinguished(specs: Iterable[DtcSpec]) -> list[DtcSpec]:
    """The specs of a run, those that share their name with another named by their id
    in reports (:attr:`DtcSpec.label`)."""
    specs = list(specs)
    counts = Counter(spec.name for spec in specs)
    return [dataclasses.replace(spec, named_by_id=counts[spec.name] > 1) for spec in specs]


def select_specs(
    specs: Sequence[DtcSpec],
    *,
    pattern: str | None = None,
    tags: Sequence[str] = (),
    rootdir: Path | None = None,
) -> list[DtcSpec]:
    """Specs that match ``pattern``, a ``-k`` expression as pytest reads it (see the
    module), and carry every tag in ``tags``. ``rootdir`` is the folder pytest would
    take for its rootdir (by default, as :func:`find_rootdir` finds it for the specs).
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


_TOKEN = re.compile(r"([()]|[\w:+\-.\[\]\\/]+)|(\S)")
"""A parenthesis or a word (words take the characters pytest's ``-k`` takes), or
another character, which none may hold."""
_OPERATORS = frozenset({"and", "or", "not", ")"})
"""The tokens that cannot stand where a word is expected."""


@dataclass(frozen=True)
class KeywordExpression:
    """A parsed ``-k`` expression; :meth:`matches` tells whether a DTC is selected."""

    text: str
    tokens: tuple[str, ...]

    @classmethod
    def parse(cls, text: str) -> KeywordExpression:
        """Parse ``text``; a malformed expression raises :class:`OptionError` in one line."""
        found = _TOKEN.findall(text)
        if other := next((other for _, other in found if other), None):
            raise OptionError(f"-k {text!r}: unexpected character {other!r}")
        parsed = cls(text, tuple(token for token, _ in found))
        parsed.matches(())  # a malformed expression fails here, before any DTC is matched
        return parsed

    def matches(self, names: Iterable[str]) -> bool:
        """Whether a DTC that pytest knows by these names (its own, its file's and
        folders', its tags and markers) is selected: recursive descent over the grammar
        (see the module)."""
        haystack = [name.lower() for name in names]
        rest = list(self.tokens[::-1])

        def fail(problem: str) -> NoReturn:
            raise OptionError(f"-k {self.text!r}: {problem}")

        def take(token: str) -> bool:
            taken = bool(rest) and rest[-1] == token
            if taken:
                rest.pop()
            return taken

        def expression() -> bool:
            values = [term()]
            while take("or"):
                values.append(term())
            return any(values)

        def term() -> bool:
            values = [factor()]
            while take("and"):
                values.append(factor())
            return all(values)

        def factor() -> bool:
            if take("not"):
                return not factor()
            if take("("):
                value = expression()
                if not take(")"):
                    fail("a '(' is not closed")
                return value
            if not rest:
                fail("ends where a word was expected")
            if rest[-1] in _OPERATORS:
                fail(f"expected a word, got {rest[-1]!r}")
            word = rest.pop().lower()
            return any(word in name for name in haystack)

        value = expression() if rest else True
        if rest:
            fail(f"unexpected {rest[-1]!r}")
        return value

"""The words beatlog prints, each with what it means (``glossary.toml`` beside this
module): ``beatlog help TERM`` prints from it and the docs' glossary page is made from it.
"""

from __future__ import annotations

import difflib
import functools
import re
import tomllib
from importlib import resources
from typing import NamedTuple

__all__ = ["Entry", "entries", "lookup", "near"]


class Entry(NamedTuple):
    """One term of the glossary."""

    term: str
    """The words as the terminal prints them."""
    meaning: str
    """What they mean, in a few plain sentences."""
    aliases: tuple[str, ...] = ()
    """Other words the terminal prints for the same thing (``HB_t`` for heartbeat)."""
    see: str | None = None
    """The documentation page that says more, relative to the site's root."""


@functools.cache
def entries() -> tuple[Entry, ...]:
    """Every entry, in the order of the glossary file."""
    text = resources.files("beatlog.report").joinpath("glossary.toml").read_text(encoding="utf-8")
    return tuple(
        Entry(
            term=row["term"],
            meaning=" ".join(row["meaning"].split()),
            aliases=tuple(row.get("aliases", ())),
            see=row.get("see"),
        )
        for row in tomllib.loads(text)["term"]
    )


def _key(words: str) -> str:
    """A term as looked up: lower case, hyphens and underscores as spaces, one space."""
    return " ".join(re.sub(r"[-_]", " ", words.casefold()).split())


@functools.cache
def _index() -> dict[str, Entry]:
    return {_key(name): entry for entry in entries() for name in (entry.term, *entry.aliases)}


def lookup(words: str) -> Entry | None:
    """The entry for ``words`` (its term or an alias, in any case; ``-`` or ``_`` for a
    space; a plural such as the ``behaviors`` heading of ``beatlog show`` by its
    singular), or None."""
    key = _key(words)
    return _index().get(key) or _index().get(key.removesuffix("s"))


def near(words: str) -> list[str]:
    """The terms nearest to ``words``, for a term the glossary lacks."""
    found = difflib.get_close_matches(_key(words), _index(), n=3, cutoff=0.6)
    return list(dict.fromkeys(_index()[key].term for key in found))

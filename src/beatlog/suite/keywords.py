"""``-k`` expressions, as pytest reads them: ``touch``, ``touch or pat``,
``obstacles and not wall``, with parentheses.

A word matches a DTC when it is a substring of one of the names pytest gives its
item, ignoring case: the DTC's name, its spec file's name, the folders between the
rootdir and the spec, its tags and the ``dtc`` marker, as pytest's ``-k`` matches a
test's name, its parents' names and its keywords; so ``beatlog test -k EXPR``
selects the DTCs that ``pytest -k EXPR`` runs. pytest is not needed:
its matcher is private (``_pytest.mark.expression``) and beatlog does not depend on
pytest, so this is a small parser of the same grammar::

    expression := term ("or" term)*
    term       := factor ("and" factor)*
    factor     := "not" factor | "(" expression ")" | word
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import NoReturn

from beatlog.errors import OptionError

__all__ = ["KeywordExpression"]

_TOKEN = re.compile(r"\s*(?:(\()|(\))|([\w:+\-.\[\]\\/]+))")
"""A parenthesis or a word; words take the characters pytest's ``-k`` takes."""
_OPERATORS = frozenset({"and", "or", "not"})

Match = Callable[[str], bool]
"""Whether a word matches what is being selected."""
Node = Callable[[Match], bool]


@dataclass(frozen=True)
class KeywordExpression:
    """A parsed ``-k`` expression; :meth:`matches` tells whether a DTC is selected."""

    text: str
    _evaluate: Node

    @classmethod
    def parse(cls, text: str) -> KeywordExpression:
        """Parse ``text``; a malformed expression raises :class:`OptionError` in one line."""
        tokens = _tokens(text)
        if not tokens:
            return cls(text, lambda match: True)
        parser = _Parser(text, tokens)
        node = parser.expression()
        if parser.position < len(tokens):
            parser.fail(f"unexpected {tokens[parser.position]!r}")
        return cls(text, node)

    def matches(self, names: Iterable[str]) -> bool:
        """Whether a DTC that pytest knows by these names (its own, its file's and
        folders', its tags and markers) is selected."""
        haystack = [name.lower() for name in names]
        return self._evaluate(lambda word: any(word.lower() in item for item in haystack))


def _tokens(text: str) -> list[str]:
    tokens: list[str] = []
    position = 0
    while position < len(text.rstrip()):
        found = _TOKEN.match(text, position)
        if found is None:
            raise OptionError(f"-k {text!r}: unexpected character {text[position:].lstrip()[0]!r}")
        tokens.append(found.group(found.lastindex or 0))
        position = found.end()
    return tokens


class _Parser:
    """Recursive descent over the tokens, building a function of the word matcher."""

    def __init__(self, text: str, tokens: list[str]) -> None:
        self.text = text
        self.tokens = tokens
        self.position = 0

    def fail(self, problem: str) -> NoReturn:
        raise OptionError(f"-k {self.text!r}: {problem}")

    def peek(self) -> str | None:
        return self.tokens[self.position] if self.position < len(self.tokens) else None

    def take(self, token: str) -> bool:
        if self.peek() == token:
            self.position += 1
            return True
        return False

    def expression(self) -> Node:
        terms = [self.term()]
        while self.take("or"):
            terms.append(self.term())
        return terms[0] if len(terms) == 1 else lambda match: any(t(match) for t in terms)

    def term(self) -> Node:
        factors = [self.factor()]
        while self.take("and"):
            factors.append(self.factor())
        return factors[0] if len(factors) == 1 else lambda match: all(f(match) for f in factors)

    def factor(self) -> Node:
        if self.take("not"):
            inner = self.factor()
            return lambda match: not inner(match)
        if self.take("("):
            inner = self.expression()
            if not self.take(")"):
                self.fail("a '(' is not closed")
            return inner
        token = self.peek()
        if token is None:
            self.fail("ends where a word was expected")
        if token in _OPERATORS | {")"}:
            self.fail(f"expected a word, got {token!r}")
        self.position += 1
        return lambda match: match(token)

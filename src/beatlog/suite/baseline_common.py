"""The most common lines of a baseline file since format 5, read a file at a time.

Outputs, blocks of digests, state changes and quiet cycles, with plain names and JSON
scalars for values, are nine lines in ten: one regular expression takes them all
(:data:`_COMMON`), and each column of each kind is read at once, each line to the value
it reads to alone (:func:`~beatlog.suite.baseline_parse.parse_line`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable, Sequence
from itertools import compress, repeat
from operator import itemgetter
from typing import Any, TypeVar

import msgspec

from beatlog.replaying.expectation import (
    ABSENT,
    AS_RECORDED,
    TracedChange,
    TracedOutput,
)
from beatlog.replaying.pins import TAG_CHARS, DigestBlock
from beatlog.replaying.state_digests import DIGEST_BYTES
from beatlog.replaying.verdict import StateChange
from beatlog.suite.baseline_text import AS_RECORDED_TEXT, QUIET

__all__ = ["common_lines"]

_JSON = json.JSONDecoder()
_INTS = msgspec.json.Decoder(list[int])
_NAMES = msgspec.json.Decoder(list[str])
_STATES = msgspec.json.Decoder(list[str | int | bool | None])
_PLAIN = r'"[^"\\\x00-\x1f]*"'
"""A JSON string without escapes or control characters: it reads as what it quotes."""
_VALUE = rf"[-+.0-9A-Za-z]+|{_PLAIN}"
"""A JSON number, literal or plain string, or no JSON at all (then the file is read line
by line): one value, as it holds no comma, bracket or space outside quotes."""
_STATE = rf"-?[0-9]+|[a-z]+|{_PLAIN}"
"""Likewise a JSON integer, literal or plain string, the values a state takes."""
_COMMON = re.compile(
    r" *([0-9]+) +([0-9]{1,6}\.[0-9]{3}) +(?:"
    rf"output ({_PLAIN}) (?:= ({_VALUE})|(absent|{AS_RECORDED_TEXT}))"
    rf"|robot_state digests ([0-9]+) ([0-9a-f]{{{2 * DIGEST_BYTES}}}) ([A-Za-z0-9+/.]+)"
    rf"|({_PLAIN}): ({_STATE}) -> ({_STATE})"
    rf"|({QUIET})"
    r")\n|(.*)\n"
)
"""A line of the most common shapes since format 5, an output, a block of digests, a
state change or a quiet cycle, with plain names and JSON scalars for values (read at once
by :func:`common_lines`, as :func:`~beatlog.suite.baseline_parse.parse_line` reads each),
else any line."""
_CYCLE, _TIME, _NAME, _VALUE_TEXT, _WORD, _COUNT, _DIGEST, _TAGS = range(8)
_BEHAVIOR, _BEFORE, _AFTER = range(8, 11)
_QUIET, _OTHER = 11, 12
_GROUPS = 14
"""What :meth:`re.Pattern.split` gives of each line: the text before it (none), and
each group of :data:`_COMMON` (None where it took no part)."""
_WORDS = {"absent": ABSENT, AS_RECORDED_TEXT: AS_RECORDED}
_Column = list[Any]
"""A group of :data:`_COMMON` in each line: its text, or None where it took no part."""
_Record = TypeVar("_Record", bound=tuple[Any, ...])


def common_lines(
    text: str,
) -> tuple[int, list[tuple[int, str]], list[tuple[list[int], list[Any]]]] | None:
    """How many lines ``text`` holds (each ended by a line feed alone, the last perhaps
    not), those not of the common shapes (:data:`_COMMON`) but empty ones, each with its
    index, and the others read, by kind (outputs, blocks of digests, state changes, quiet
    cycles), each with the indices of its lines; None when one of them does not read, to
    be read line by line (and refused there)."""
    parts = _COMMON.split(text if text[-1:] == "\n" else text + "\n")  # a match a line
    columns = [parts[group::_GROUPS] for group in range(1, _GROUPS)]
    del parts  # not looked into by the garbage collector while the lines are read
    indices = range(len(columns[_OTHER]))
    kinds = []
    try:
        for marker, read in (
            (_NAME, _outputs),
            (_COUNT, _blocks),
            (_BEFORE, _changes),
            (_QUIET, _quiet),
        ):
            where = list(compress(indices, columns[marker]))
            kinds.append((where, read(columns, where) if where else []))
    except ValueError:
        return None
    other = columns[_OTHER]
    return len(indices), [(index, other[index]) for index in compress(indices, other)], kinds


def _picked(columns: list[_Column], where: list[int], *which: int) -> list[Sequence[Any]]:
    """The columns ``which`` of the lines ``where`` (at least one), each taken at once."""
    if len(where) == 1:
        return [(columns[column][where[0]],) for column in which]
    take = itemgetter(*where)  # a tuple of as many, as there are two or more
    return [take(columns[column]) for column in which]


def _outputs(columns: list[_Column], where: list[int]) -> list[Any]:
    cycles, times, names, value, word = _picked(
        columns, where, _CYCLE, _TIME, _NAME, _VALUE_TEXT, _WORD
    )
    values = iter(_decoded(filter(None, value)))
    said = [_WORDS[text] if text else next(values) for text in word]
    return _records(
        TracedOutput,
        _shared(cycles, _ints),
        _shared(times, _times_ns),
        _shared(names, _names),
        said,
    )


def _blocks(columns: list[_Column], where: list[int]) -> list[Any]:
    cycles, times, counts, digests, tags = _picked(
        columns, where, _CYCLE, _TIME, _COUNT, _DIGEST, _TAGS
    )
    if list(map(len, tags)) != [TAG_CHARS * count for count in _listed(_INTS, counts)]:
        raise ValueError("a block of digests holds not as many tags as it says")
    return _records(
        DigestBlock, _listed(_INTS, cycles), _times_ns(times), tags, map(bytes.fromhex, digests)
    )


def _changes(columns: list[_Column], where: list[int]) -> list[Any]:
    cycles, times, behaviors, before, after = _picked(
        columns, where, _CYCLE, _TIME, _BEHAVIOR, _BEFORE, _AFTER
    )
    changes = _records(
        StateChange,
        _shared(behaviors, _names),
        _shared(before, _states),
        _shared(after, _states),
    )
    return _records(TracedChange, _shared(cycles, _ints), _shared(times, _times_ns), changes)


def _quiet(columns: list[_Column], where: list[int]) -> list[Any]:
    cycles, times = _picked(columns, where, _CYCLE, _TIME)
    return list(zip(_listed(_INTS, cycles), _times_ns(times), strict=True))


def _shared(texts: Sequence[str], read: Callable[[Sequence[str]], list[Any]]) -> list[Any]:
    """The values of ``texts`` as ``read`` reads them, each distinct text read once: the
    lines of one cycle, or naming one field, behavior or state, hold one object for it,
    not one each (in a big baseline they would cost more than the values)."""
    distinct = list(dict.fromkeys(texts))
    values = dict(zip(distinct, read(distinct), strict=True))
    return [values[text] for text in texts]


def _ints(texts: Sequence[str]) -> list[int]:
    return _listed(_INTS, texts)


def _names(texts: Sequence[str]) -> list[str]:
    return _listed(_NAMES, texts)


def _states(texts: Sequence[str]) -> list[Any]:
    return _listed(_STATES, texts)


def _listed(decoder: msgspec.json.Decoder[list[Any]], values: Sequence[str]) -> list[Any]:
    """JSON values, each one whole, read at once by ``decoder``: plain strings, integers
    and flags, each to what :data:`_JSON` reads it to (msgspec reads them for a third
    of the instructions)."""
    return decoder.decode("[" + ",".join(values) + "]")


def _times_ns(seconds: Sequence[str]) -> list[int]:
    """Robot times in seconds, with three decimals, in nanoseconds, as a line alone reads
    each (``round(float(seconds) * 1e9)``: under 10**6 s, the float is within 0.13 ns of
    the time, and rounds to it for each of the 10**9 times, checked one by one). Read at
    once, as JSON integers: each time's milliseconds, without leading zeros, and six
    zeros; one by one where one has them still (0 s, or a time written ``00.030``)."""
    text = "," + ",".join(seconds)
    for under_a_second in (",0.00", ",0.0", ",0."):
        text = text.replace(under_a_second, ",")
    try:
        return _INTS.decode(f"[{text[1:].replace('.', '').replace(',', '000000,')}000000]")
    except ValueError:
        return [int(time.replace(".", "")) * 1_000_000 for time in seconds]


def _decoded(values: Iterable[str]) -> list[Any]:
    """JSON values, each one whole, read at once: each as :data:`_JSON` reads it alone."""
    decoded: list[Any] = _JSON.raw_decode("[" + ",".join(values) + "]")[0]
    return decoded


def _records(record: type[_Record], *fields: Iterable[Any]) -> list[_Record]:
    """A ``record`` (a NamedTuple) of each row of ``fields``, made at once, as
    ``record._make`` makes one."""
    return list(map(tuple.__new__, repeat(record), zip(*fields, strict=True)))

"""The lines of a baseline file, read: each line of the current format to a value.

Reading never evaluates anything: names, states and values are JSON (or msgpack in
hex, :func:`~beatlog.baseline.write.format_value`), and each line either parses whole
or raises :class:`ValueError` saying what was expected. Outputs, blocks of digests,
state changes and quiet cycles, with plain names and JSON scalars for values, are nine
lines in ten: one regular expression takes them all (:data:`_COMMON`), a block of lines
at a time (:meth:`ParsedLines.read_common`), and each column of each kind is read at
once, each line to the value it reads to alone (:func:`parse_line`).
"""

from __future__ import annotations

import bisect
import functools
import json
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from itertools import compress
from typing import Any, TypeVar

import msgspec

from beatlog.baseline.write import (
    AS_RECORDED_TEXT,
    MSGPACK,
    NONE,
    OPEN_LOOP,
    OUTPUT,
    QUIET,
    ROBOT_STATE,
    RUN_FIRST,
)
from beatlog.log.format import DECODE_ERRORS
from beatlog.replay.approved_state_lines import DIGEST_BYTES, TAG_CHARS, ApprovedRun, DigestBlock
from beatlog.replay.baseline import (
    ABSENT,
    AS_RECORDED,
    TracedOutput,
    TracedStateChange,
)
from beatlog.replay.draws import ApprovedDraws
from beatlog.replay.verdict import StateChange

__all__ = ["ParsedLines", "line_feeds", "parse_line"]

_CHANGE_LINE = re.compile(r"\s*(?P<cycle>\d+)\s+(?P<time>\d+\.\d{3})\s+(?P<change>.*)")
_DRAW_HEAD = re.compile(r'draws (?P<behavior>"[^"\\]*(?:\\.[^"\\]*)*"): ')
"""The start of a draws line, up to its recorded draw: the behavior is the first quoted
string, up to its first quote not escaped."""
_TO = " -> "
_IN_CYCLES = " in cycles "
_RUN = re.compile(
    r"otherwise in (?P<first>\d+)\.\.(?P<last>\d+) \((?P<cycles>\d+) cycles?\): (?P<rest>.*)"
)
_DIGESTS = re.compile(
    rf"digests (?P<cycles>\d+) (?P<digest>[0-9a-f]{{{2 * DIGEST_BYTES}}}) (?P<tags>[A-Za-z0-9+/.]+)"
)
_JSON = json.JSONDecoder()
_OTHER_BREAKS = "\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"
"""What :meth:`str.splitlines` breaks lines at besides a line feed."""


@dataclass
class ParsedLines:
    """The lines of a baseline file read so far, by kind."""

    changes: list[TracedStateChange] = field(default_factory=list)
    outputs: list[TracedOutput] = field(default_factory=list)
    runs: list[ApprovedRun] = field(default_factory=list)
    blocks: list[DigestBlock] = field(default_factory=list)
    draws: list[ApprovedDraws] = field(default_factory=list)
    quiet: list[tuple[int, int]] = field(default_factory=list)
    open_loop: tuple[int, int] | None = None

    def read_common(self, text: str, start: int) -> Iterator[tuple[int, str]]:
        """Read the lines of the most common shapes at once, and yield each other line but
        empty ones with its number (``text`` as :func:`line_feeds` gives it, numbered from
        ``start``), in order, each to be read (:meth:`add`) or skipped before the next is
        asked for, so that the lines of each kind are kept in the order of the file. When
        a line of a common shape does not read, every line is yielded, to be refused at
        the right line.
        """
        common = _common_lines(text)
        if common is None:
            yield from enumerate(text.splitlines(), start)
            return
        count, others, kinds = common
        kept: tuple[list[Any], ...] = (self.outputs, self.blocks, self.changes, self.quiet)
        taken = [0] * len(kept)
        previous = -1
        for index, line in [*others, (count, "")]:
            if index > previous + 1:  # lines of the common shapes since the previous other
                for kind, (rows, items) in enumerate(kinds):
                    upto = bisect.bisect_left(rows, index, taken[kind])
                    kept[kind].extend(items[taken[kind] : upto])
                    taken[kind] = upto
            if index < count:
                yield start + index, line
            previous = index

    def add(self, line: str) -> None:
        """Read one line of the body of a baseline file and keep it.

        :raises ValueError: the line is not one that format holds, or a second
            ``open loop`` line.
        """
        if line[:6] == "draws ":
            self.draws.append(_parse_draw(line))
            return
        parsed = parse_line(line)
        if isinstance(parsed, TracedOutput):
            self.outputs.append(parsed)
        elif isinstance(parsed, TracedStateChange):
            self.changes.append(parsed)
        elif isinstance(parsed, ApprovedRun):
            self.runs.append(parsed)
        elif isinstance(parsed, DigestBlock):
            self.blocks.append(parsed)
        elif parsed[2] == QUIET:
            self.quiet.append(parsed[:2])
        elif self.open_loop is not None:
            raise ValueError("a second 'open loop' line")
        else:
            self.open_loop = parsed[:2]


def line_feeds(block: str) -> tuple[str, int]:
    """A block of whole lines as :meth:`str.splitlines` breaks them, each ended by a line
    feed alone (the last perhaps not), for :meth:`ParsedLines.read_common`, and how many
    lines it holds."""
    if any(other in block for other in _OTHER_BREAKS):
        lines = block.splitlines()
        return "\n".join(lines) + "\n", len(lines)
    return block, block.count("\n") + (block[-1:] not in ("\n", ""))


def _parse_draw(line: str) -> ApprovedDraws:
    head = _DRAW_HEAD.match(line)
    rest = line[head.end() :] if head else ""
    split = rest.rfind(_IN_CYCLES)  # the only one that numbers may follow
    arrow = rest.find(_TO, 1, split - 1) if split > 0 else -1  # the first, a draw each side
    cycles = rest[split + len(_IN_CYCLES) :]
    if (
        head is None
        or arrow < 0
        or "\n" in rest  # as a regular expression's ``.`` takes no line break
        or not cycles[:1].isdecimal()  # numbers (digits as \d takes them), single spaces
        or not cycles.replace(" ", "").isdecimal()
        or "  " in cycles
        or cycles.endswith(" ")
    ):
        raise ValueError("expected 'draws \"behavior\": RECORDED -> ASKED in cycles N N ...'")
    behavior = _JSON.raw_decode(head["behavior"])[0]  # all of it, up to its one last quote
    recorded, asked = rest[:arrow], rest[arrow + len(_TO) : split]
    if recorded == asked:
        raise ValueError(f"a draw of {asked} as recorded is no difference")
    return ApprovedDraws(
        behavior,
        None if recorded == NONE else recorded,
        None if asked == NONE else asked,
        tuple(map(int, cycles.split())),
    )


def _time_ns(seconds: str) -> int:
    """A line's robot time, written in seconds with three decimals, in nanoseconds."""
    return round(float(seconds) * 1e9)


def parse_line(
    line: str,
) -> TracedStateChange | TracedOutput | ApprovedRun | DigestBlock | tuple[int, int, str]:
    """A line of the cycle columns; an ``open loop`` or quiet line as its cycle, time and
    text."""
    found = _CHANGE_LINE.fullmatch(line)
    if found is None:
        raise ValueError(
            "expected 'CYCLE TIME \"behavior\": BEFORE -> AFTER', "
            "'CYCLE TIME output \"field\" = VALUE' or 'CYCLE TIME robot_state ...'"
        )
    cycle, time_ns, text = int(found["cycle"]), _time_ns(found["time"]), found["change"]
    if text in (OPEN_LOOP, QUIET):
        return cycle, time_ns, text
    if text.startswith(OUTPUT):
        name, value = _parse_value(text[len(OUTPUT) :])
        return TracedOutput(cycle, time_ns, name, value)
    if text.startswith(ROBOT_STATE):
        return _parse_state(text[len(ROBOT_STATE) :], cycle, time_ns)
    return TracedStateChange(cycle, time_ns, _parse_change(text))


def _parse_value(text: str) -> tuple[str, Any]:
    name, end = _JSON.raw_decode(text)
    if not isinstance(name, str):
        raise ValueError("the field must be a JSON string")
    rest = text[end:].rstrip()
    if rest == " absent":
        return name, ABSENT
    if rest == " " + AS_RECORDED_TEXT:
        return name, AS_RECORDED
    end = _expect(text, end, " = ")
    return name, _decode_value(text[end:].rstrip())


def _decode_value(value_text: str) -> Any:
    """A value as :func:`~beatlog.baseline.write.format_value` writes it."""
    if value_text.startswith(MSGPACK):
        try:
            return msgspec.msgpack.decode(bytes.fromhex(value_text[len(MSGPACK) :]))
        except (ValueError, *DECODE_ERRORS) as exc:
            raise ValueError(f"a damaged msgpack value: {exc}") from None
    value, end = _JSON.raw_decode(value_text)
    if end != len(value_text):
        raise ValueError(f"unexpected {value_text[end:]!r} after the value")
    return value


def _parse_state(text: str, cycle: int, time_ns: int) -> ApprovedRun | DigestBlock:
    """A robot-state line: a run of pinned cycles, or a block of their digests."""
    block = _DIGESTS.fullmatch(text.rstrip())
    if block is not None:
        tags = block["tags"]
        expected = int(block["cycles"]) * TAG_CHARS
        if len(tags) != expected:
            raise ValueError(f"expected {expected} characters of tags, found {len(tags)}")
        return DigestBlock(cycle, time_ns, tags, bytes.fromhex(block["digest"]))
    run = _RUN.fullmatch(text.rstrip())
    if run is None:
        raise ValueError(
            "expected 'robot_state otherwise in FIRST..LAST (N cycles): [FIELDS], first "
            "{VALUES}' or 'robot_state digests N DIGEST TAGS'"
        )
    rest = run["rest"]
    fields, end = _JSON.raw_decode(rest)
    if not isinstance(fields, list) or not all(isinstance(name, str) for name in fields):
        raise ValueError("the fields must be a JSON list of strings")
    end = _expect(rest, end, RUN_FIRST)
    first = _decode_value(rest[end:])
    if not isinstance(first, dict) or not all(isinstance(name, str) for name in first):
        raise ValueError("the first cycle's values must be a JSON object")
    if int(run["first"]) != cycle:
        raise ValueError(f"a run of cycles from {run['first']} on a line of cycle {cycle}")
    return ApprovedRun(cycle, time_ns, int(run["last"]), int(run["cycles"]), tuple(fields), first)


def _parse_change(text: str) -> StateChange:
    behavior, end = _JSON.raw_decode(text)
    end = _expect(text, end, ": ")
    before, end = _JSON.raw_decode(text, end)
    end = _expect(text, end, " -> ")
    after, end = _JSON.raw_decode(text, end)
    if end != len(text.rstrip()):
        raise ValueError(f"unexpected {text[end:]!r} after the state")
    if not isinstance(behavior, str):
        raise ValueError("the behavior must be a JSON string")
    for state in (before, after):
        if not isinstance(state, str | int | bool | None):
            raise ValueError(f"a state must be a string, number, flag or null, not {state!r}")
    return StateChange(behavior, before, after)


def _expect(text: str, position: int, separator: str) -> int:
    if not text.startswith(separator, position):
        raise ValueError(f"expected {separator.strip()!r} at column {position + 1}")
    return position + len(separator)


_PLAIN = r'"[^"\\\x00-\x1f]*"'
"""A JSON string without escapes or control characters: it reads as what it quotes."""
_VALUE = rf"[-+.0-9A-Za-z]+|{_PLAIN}"
"""A JSON number, literal or plain string, or no JSON at all (then the file is read line
by line): one value, as it holds no comma, bracket or space outside quotes."""
_STATE = rf"-?[0-9]+|[a-z]+|{_PLAIN}"
"""Likewise a JSON integer, literal or plain string, the values a state takes."""
# Speed: read at once, not line by line, a whole replay judged against a 16 MiB baseline
# of outputs takes 37 % fewer instructions (17.5 G against 27.8 G, cachegrind; 4.7 s of
# CPU against 9.1 s); tests/baseline/test_read.py pins each shape against parse_line.
_COMMON = re.compile(
    r" *([0-9]+) +([0-9]{1,6}\.[0-9]{3}) +(?:"
    rf"output ({_PLAIN}) (?:= ({_VALUE})|(absent|{AS_RECORDED_TEXT}))"
    rf"|robot_state digests ([0-9]+) ([0-9a-f]{{{2 * DIGEST_BYTES}}}) ([A-Za-z0-9+/.]+)"
    rf"|({_PLAIN}): ({_STATE}) -> ({_STATE})"
    rf"|({QUIET})"
    r")\n|(.*)\n"
)
"""A line of the most common shapes (an output, a block of digests, a state change or a
quiet cycle, with plain names and JSON scalars for values), else any line."""
_CYCLE, _TIME, _NAME, _VALUE_TEXT, _WORD, _COUNT, _DIGEST, _TAGS = range(8)
_BEHAVIOR, _BEFORE, _AFTER, _QUIET, _OTHER = range(8, 13)
_GROUPS = 14
"""What :meth:`re.Pattern.split` gives of each line: the text before it (none), and
each group of :data:`_COMMON` (None where it took no part)."""
_WORDS = {"absent": ABSENT, AS_RECORDED_TEXT: AS_RECORDED}
_Column = list[Any]
"""A group of :data:`_COMMON` in each line: its text, or None where it took no part."""
_Record = TypeVar("_Record", bound=tuple[Any, ...])


def _common_lines(
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


def _picked(columns: list[_Column], where: list[int], *which: int) -> list[list[Any]]:
    """The columns ``which`` of the lines ``where``."""
    return [list(map(columns[column].__getitem__, where)) for column in which]


def _outputs(columns: list[_Column], where: list[int]) -> list[Any]:
    cycles, times, names, value, word = _picked(
        columns, where, _CYCLE, _TIME, _NAME, _VALUE_TEXT, _WORD
    )
    values = iter(_JSON.raw_decode("[" + ",".join(filter(None, value)) + "]")[0])
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
    if list(map(len, tags)) != [TAG_CHARS * count for count in _ints(counts)]:
        raise ValueError("a block of digests holds not as many tags as it says")
    return _records(DigestBlock, _ints(cycles), _times_ns(times), tags, map(bytes.fromhex, digests))


def _changes(columns: list[_Column], where: list[int]) -> list[Any]:
    cycles, times, behaviors, before, after = _picked(
        columns, where, _CYCLE, _TIME, _BEHAVIOR, _BEFORE, _AFTER
    )
    changes = _records(
        StateChange, _shared(behaviors, _names), _shared(before, _states), _shared(after, _states)
    )
    return _records(TracedStateChange, _shared(cycles, _ints), _shared(times, _times_ns), changes)


def _quiet(columns: list[_Column], where: list[int]) -> list[Any]:
    cycles, times = _picked(columns, where, _CYCLE, _TIME)
    return list(zip(_ints(cycles), _times_ns(times), strict=True))


def _shared(texts: list[str], read: Callable[[list[str]], list[Any]]) -> list[Any]:
    """The values of ``texts`` as ``read`` reads them, each distinct text read once: the
    lines of one cycle, or naming one field, behavior or state, hold one object for it,
    not one each (in a big baseline they would cost more than the values)."""
    distinct = list(dict.fromkeys(texts))
    values = dict(zip(distinct, read(distinct), strict=True))
    return [values[text] for text in texts]


def _listed(decoder: msgspec.json.Decoder[list[Any]], values: list[str]) -> list[Any]:
    """JSON values, each one whole (plain strings, integers and flags), read at once, each
    to what :data:`_JSON` reads it to."""
    return decoder.decode("[" + ",".join(values) + "]")


_ints = functools.partial(_listed, msgspec.json.Decoder(list[int]))
_names = functools.partial(_listed, msgspec.json.Decoder(list[str]))
_states = functools.partial(_listed, msgspec.json.Decoder(list[str | int | bool | None]))


def _times_ns(seconds: list[str]) -> list[int]:
    return [round(float(time) * 1e9) for time in seconds]  # as _time_ns reads each


def _records(record: type[_Record], *fields: Iterable[Any]) -> list[_Record]:
    """A ``record`` (a NamedTuple) of each row of ``fields``."""
    return [record(*row) for row in zip(*fields, strict=True)]

"""The lines of a baseline file, read: each line of any format version to a value.

Reading never evaluates anything: names, states and values are JSON (or msgpack in
hex, :func:`~beatlog.suite.baseline_text.format_value`), and each line either parses
whole or raises :class:`ValueError` saying what was expected. The most common lines
since format 5 are read a block of lines at a time (:meth:`ParsedLines.read_common`),
each to the value it reads to alone.
"""

from __future__ import annotations

import bisect
import json
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import msgspec

from beatlog.log.format import DECODE_ERRORS
from beatlog.replaying.draws import DrawRule
from beatlog.replaying.expectation import (
    ABSENT,
    AS_RECORDED,
    TracedChange,
    TracedOutput,
    TracedState,
)
from beatlog.replaying.pins import TAG_CHARS, DigestBlock, PinnedRun
from beatlog.replaying.state_digests import DIGEST_BYTES
from beatlog.replaying.verdict import StateChange
from beatlog.suite.baseline_common import common_lines
from beatlog.suite.baseline_text import (
    AS_RECORDED_TEXT,
    MSGPACK,
    NONE,
    OPEN_LOOP,
    OUTPUT,
    QUIET,
    ROBOT_STATE,
    RUN_FIRST,
)

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
_CYCLES = msgspec.json.Decoder(tuple[int, ...])


class _OpenLoop(NamedTuple):
    cycle: int
    time_ns: int


class _Quiet(NamedTuple):
    cycle: int
    time_ns: int


@dataclass
class ParsedLines:
    """The lines of a baseline file read so far, by kind."""

    changes: list[TracedChange] = field(default_factory=list)
    outputs: list[TracedOutput] = field(default_factory=list)
    states: list[TracedState] = field(default_factory=list)
    runs: list[PinnedRun] = field(default_factory=list)
    blocks: list[DigestBlock] = field(default_factory=list)
    draws: list[DrawRule] = field(default_factory=list)
    quiet: list[tuple[int, int]] = field(default_factory=list)
    open_loop: tuple[int, int] | None = None

    def read_common(self, text: str, version: int, start: int) -> Iterator[tuple[int, str]]:
        """Read the lines of the most common shapes at once, and yield each other line but
        empty ones with its number (``text``: lines each ended by a line feed alone, the
        last perhaps not, as :func:`line_feeds` gives them, numbered from ``start``), in
        order: comments, and lines for :meth:`add`, each to be read or skipped before the
        next is asked for, so that the lines of each kind are kept in the order of the file.

        Before format 5, or when a line of a common shape does not read (a value that is
        no JSON, a block of digests without as many tags as it says), every line is
        yielded, to be read one by one and refused at the right line.
        """
        common = common_lines(text) if version >= 5 else None
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

    def add(self, line: str, version: int) -> None:
        """Read one line of the body of a file of format ``version`` and keep it.

        :raises ValueError: the line is not one that format holds, or a second
            ``open loop`` line.
        """
        parsed = _parse_draw(line, version) if line[:6] == "draws " else parse_line(line, version)
        if isinstance(parsed, _OpenLoop):
            if self.open_loop is not None:
                raise ValueError("a second 'open loop' line")
            self.open_loop = (parsed.cycle, parsed.time_ns)
        elif isinstance(parsed, _Quiet):
            self.quiet.append((parsed.cycle, parsed.time_ns))
        elif isinstance(parsed, DrawRule):
            self.draws.append(parsed)
        elif isinstance(parsed, TracedOutput):
            self.outputs.append(parsed)
        elif isinstance(parsed, TracedState):
            self.states.append(parsed)
        elif isinstance(parsed, PinnedRun):
            self.runs.append(parsed)
        elif isinstance(parsed, DigestBlock):
            self.blocks.append(parsed)
        else:
            self.changes.append(parsed)


def line_feeds(block: str) -> tuple[str, int]:
    """A block of whole lines, each ended by a line feed alone (the last perhaps not),
    as :meth:`str.splitlines` breaks them, for :meth:`ParsedLines.read_common`, and how
    many lines it holds: a block with no other line breaks is kept whole, not cut into
    a string a line."""
    if any(other in block for other in _OTHER_BREAKS):
        lines = block.splitlines()
        return "\n".join(lines) + "\n", len(lines)
    return block, block.count("\n") + (block[-1:] not in ("\n", ""))


_Line = (
    TracedChange | TracedOutput | TracedState | PinnedRun | DigestBlock | DrawRule | _OpenLoop
) | _Quiet


def _parse_draw(line: str, version: int) -> DrawRule:
    if version < 4:
        raise ValueError(f"a format {version} baseline holds no draws")
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
    return DrawRule(
        behavior,
        None if recorded == NONE else recorded,
        None if asked == NONE else asked,
        _cycles(cycles),
    )


def _cycles(numbers: str) -> tuple[int, ...]:
    """The cycles of a draws line, as :func:`int` reads each: at once as JSON, unless
    they are not JSON (a leading zero, digits other than ASCII)."""
    try:
        return _CYCLES.decode(f"[{numbers.replace(' ', ',')}]")
    except ValueError:
        return tuple(map(int, numbers.split()))


def _time_ns(seconds: str) -> int:
    """A line's robot time, written in seconds with three decimals, in nanoseconds."""
    return round(float(seconds) * 1e9)


def parse_line(line: str, version: int) -> _Line:
    """A line of the cycle columns, as a file of format ``version`` holds it."""
    found = _CHANGE_LINE.fullmatch(line)
    if found is None:
        raise ValueError(
            "expected 'CYCLE TIME \"behavior\": BEFORE -> AFTER', "
            "'CYCLE TIME output \"field\" = VALUE' or 'CYCLE TIME robot_state ...'"
        )
    cycle, time_ns, text = int(found["cycle"]), _time_ns(found["time"]), found["change"]
    if text == OPEN_LOOP and version >= 4:
        return _OpenLoop(cycle, time_ns)
    if text == QUIET and version >= 5:
        return _Quiet(cycle, time_ns)
    if text.startswith(OUTPUT):
        if version < 2:
            raise ValueError("a format 1 baseline holds no outputs")
        name, value = _parse_value(text[len(OUTPUT) :], as_recorded=version >= 5)
        return TracedOutput(cycle, time_ns, name, value)
    if text.startswith(ROBOT_STATE):
        if version < 3:
            raise ValueError(f"a format {version} baseline holds no robot states")
        if version >= 4:
            return _parse_pin(text[len(ROBOT_STATE) :], cycle, time_ns)
        name, value = _parse_value(text[len(ROBOT_STATE) :])
        if value is ABSENT:
            raise ValueError("a robot-state field is never absent")
        return TracedState(cycle, time_ns, name, value)
    return TracedChange(cycle, time_ns, _parse_change(text))


def _parse_value(text: str, *, as_recorded: bool = False) -> tuple[str, Any]:
    name, end = _JSON.raw_decode(text)
    if not isinstance(name, str):
        raise ValueError("the field must be a JSON string")
    rest = text[end:].rstrip()
    if rest == " absent":
        return name, ABSENT
    if as_recorded and rest == " " + AS_RECORDED_TEXT:
        return name, AS_RECORDED
    end = _expect(text, end, " = ")
    return name, _decode_value(text[end:].rstrip())


def _decode_value(value_text: str) -> Any:
    """A value as :func:`~beatlog.suite.baseline_text.format_value` writes it."""
    if value_text.startswith(MSGPACK):
        try:
            return msgspec.msgpack.decode(bytes.fromhex(value_text[len(MSGPACK) :]))
        except (ValueError, *DECODE_ERRORS) as exc:
            raise ValueError(f"a damaged msgpack value: {exc}") from None
    value, end = _JSON.raw_decode(value_text)
    if end != len(value_text):
        raise ValueError(f"unexpected {value_text[end:]!r} after the value")
    return value


def _parse_pin(text: str, cycle: int, time_ns: int) -> PinnedRun | DigestBlock:
    """A robot-state line since format 4: a run of pinned cycles, or a block of their digests."""
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
    return PinnedRun(cycle, time_ns, int(run["last"]), int(run["cycles"]), tuple(fields), first)


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

"""Expected state changes, outputs, robot states and draws approved after an intended change.

Recordings are immutable: when behaviors (or, in sensor-level replay, perception)
change on purpose, the new state changes and outputs go to a *pending* file beside the
spec (``NAME.dtc.pending``), are reviewed, and once approved become the *expected*
file (``NAME.dtc.expected``) that replay judges against instead of the recording.
Both are plain text, one state change, output change or robot-state field a line, so
a re-baseline reads as a diff in code review::

    # beatlog expected state changes, outputs, robot states and draws, format 4
    # spec avoid-pole
    # log avoid-pole.beatlog sha256 5f0c...
    draws "wander": uniform(0.8, 1.6) -> uniform(0.7, 1.5) in cycles 12 97 240
    draws "escape": - -> uniform(4.0, 8.0) in cycles 12 12
    #  cycle      time  "behavior": before -> after | output/robot_state "field" = value
          0     0.030  output "speed" = 0.5
         12     0.360  open loop
         12     0.360  robot_state "distance" = 0.55
         12     0.360  "avoid": "idle" -> "turning"
         12     0.360  output "speed" = 0.0
         40     1.200  output "turn" absent

An output line appears only in the cycles where that field's value changes (cycle 0
gives the initial values); ``absent`` means the field is no longer output. A
robot-state line pins, for sensor-level replay, a field the perception step rebuilds
otherwise than the recorded RS_t, in each cycle where it does: the recorded state with
these fields is what perception must rebuild (none: the recording itself). Behavior
names, states and values are JSON, floats written so they read back bit for bit
(``NaN``, ``Infinity``, ``-Infinity``, ``-0.0`` included); a value JSON cannot hold
exactly (a NaN with a payload, bytes) is written as ``msgpack:HEX``, its msgpack
encoding. Loading a baseline never evaluates anything, and a file larger than
:data:`MAX_BASELINE_BYTES` is refused.

A ``draws`` line approves draws that replay makes otherwise than recorded, in the
cycles listed (a cycle once per draw; :mod:`beatlog.replay.draws`): a recorded request
re-mapped to the one asked for now, a new draw (``-`` for the recorded side) or a
recorded one left unused (``-`` for the asked side). A baseline is judged in living
replay, cycle by cycle: any other draw made otherwise, or an approved one not made,
diverges in its cycle. The ``open loop`` line marks the first cycle whose state changes or outputs
leave the recording's: from there the recorded world (RS_t, samples) no longer answers
to what the changed behaviors do, and the session is worth recording again when
convenient.

Format 3 files approve no draws: replay must draw as recorded. Format 2 files pin no
robot states: perception must rebuild the recording. Format 1 files (state changes
only) pin no outputs either, so replay judges outputs against the recording and says
so when they differ; re-approve to pin them.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import BaselineError, NotABeatlogError
from beatlog.files import irregular_file_problem, replacing
from beatlog.log.format import DECODE_ERRORS
from beatlog.replay.draws import DrawRule
from beatlog.replay.expectation import ABSENT, Expectation, TracedChange, TracedOutput, TracedState
from beatlog.replay.verdict import StateChange
from beatlog.suite.spec import SPEC_SUFFIX

__all__ = [
    "EXPECTED_SUFFIX",
    "MAX_BASELINE_BYTES",
    "PENDING_SUFFIX",
    "Baseline",
    "expected_path",
    "format_lines",
    "log_digest",
    "pending_path",
    "read_baseline",
    "write_baseline",
]

EXPECTED_SUFFIX = ".dtc.expected"
PENDING_SUFFIX = ".dtc.pending"
MAX_BASELINE_BYTES = 1 << 28
"""A baseline is a line per change; a file bigger than this is not one."""
_MAGIC = "# beatlog expected state changes, outputs, robot states and draws, format 4"
_MAGIC_3 = "# beatlog expected state changes, outputs and robot states, format 3"
_MAGIC_2 = "# beatlog expected state changes and outputs, format 2"
_MAGIC_1 = "# beatlog expected state changes, format 1"
_VERSIONS = {_MAGIC: 4, _MAGIC_3: 3, _MAGIC_2: 2, _MAGIC_1: 1}
_LOG_LINE = re.compile(r"# log (?P<name>.+) sha256 (?P<digest>[0-9a-f]{64})")
_CHANGE_LINE = re.compile(r"\s*(?P<cycle>\d+)\s+(?P<time>\d+\.\d{3})\s+(?P<change>.*)")
_DRAW_LINE = re.compile(
    r'draws (?P<behavior>"(?:[^"\\]|\\.)*"): '
    r"(?P<recorded>.+?) -> (?P<asked>.+) in cycles (?P<cycles>\d+(?: \d+)*)"
)
_NONE = "-"
_OPEN_LOOP = "open loop"
_OUTPUT = "output "
_ROBOT_STATE = "robot_state "
_MSGPACK = "msgpack:"
_JSON = json.JSONDecoder()
_SORTED = msgspec.msgpack.Encoder(order="sorted")


@dataclass(frozen=True)
class Baseline:
    """A baseline file: the log it was made from, its state changes, its outputs and the
    robot-state fields it pins."""

    path: Path
    log_digest: str
    changes: tuple[TracedChange, ...]
    outputs: tuple[TracedOutput, ...] | None = None
    """The output changes; None in a format 1 file, which pins no outputs."""
    robot_states: tuple[TracedState, ...] = ()
    """The robot-state fields perception rebuilds otherwise than recorded (format 3)."""
    draws: tuple[DrawRule, ...] = ()
    """The draws replay may make otherwise than recorded (format 4)."""
    open_loop: tuple[int, int] | None = None
    """Where the behaviors left the recording, when they do (format 4)."""

    @property
    def expectation(self) -> Expectation:
        """What replay judges against with this baseline."""
        return Expectation(
            self.changes, self.outputs, self.robot_states, self.draws, self.open_loop
        )


def _base(spec: Path) -> str:
    name = spec.name
    return name[: -len(SPEC_SUFFIX)] if name.endswith(SPEC_SUFFIX) else spec.stem


def expected_path(spec: Path) -> Path:
    """Where the approved baseline of the spec at ``spec`` lives."""
    return spec.with_name(_base(spec) + EXPECTED_SUFFIX)


def pending_path(spec: Path) -> Path:
    """Where the pending (not yet approved) baseline of the spec at ``spec`` lives."""
    return spec.with_name(_base(spec) + PENDING_SUFFIX)


def log_digest(log: Path) -> str:
    """The SHA-256 of a session log, binding a baseline to the recording it was made from."""
    problem = irregular_file_problem(log)
    if problem is not None:
        raise NotABeatlogError(log, problem)
    digest = hashlib.sha256()
    try:
        with log.open("rb") as file:
            for block in iter(lambda: file.read(1 << 20), b""):
                digest.update(block)
    except OSError as exc:
        raise BaselineError(log, f"cannot read: {exc.strerror or exc}") from None
    return digest.hexdigest()


def format_lines(
    changes: Iterable[TracedChange],
    outputs: Iterable[TracedOutput] | None = None,
    robot_states: Iterable[TracedState] = (),
    open_loop: tuple[int, int] | None = None,
) -> list[str]:
    """One text line per robot-state field, state change and output change, by cycle,
    as baseline files hold them: in each cycle in that order, as replay meets them,
    after the line that says the behaviors left the recording there (``open_loop``)."""
    keyed = [(s.cycle, 0, _value_line(_ROBOT_STATE, s)) for s in robot_states]
    if open_loop is not None:
        cycle, time_ns = open_loop
        keyed.append((cycle, -1, f"{cycle:>8} {time_ns / 1e9:>9.3f}  {_OPEN_LOOP}"))
    keyed.extend((c.cycle, 1, _change_line(c)) for c in changes)
    keyed.extend((o.cycle, 2, _value_line(_OUTPUT, o)) for o in outputs or ())
    keyed.sort(key=lambda item: item[:2])  # stable: the order within a cycle is kept
    return [line for _, _, line in keyed]


def _change_line(traced: TracedChange) -> str:
    cycle, time_ns, change = traced
    return (
        f"{cycle:>8} {time_ns / 1e9:>9.3f}  {json.dumps(change.behavior)}: "
        f"{json.dumps(change.before)} -> {json.dumps(change.after)}"
    )


def _value_line(kind: str, traced: TracedOutput | TracedState) -> str:
    cycle, time_ns, name, value = traced
    what = "absent" if value is ABSENT else f"= {_format_value(value)}"
    return f"{cycle:>8} {time_ns / 1e9:>9.3f}  {kind}{json.dumps(name)} {what}"


def _format_value(value: Any) -> str:
    """JSON when it reads back bit for bit, else the msgpack encoding in hex."""
    try:
        text = json.dumps(value, sort_keys=True)
        if _SORTED.encode(json.loads(text)) == _SORTED.encode(value):
            return text
    except (TypeError, ValueError):
        pass
    return _MSGPACK + _SORTED.encode(value).hex()


def write_baseline(
    path: Path,
    *,
    spec_name: str,
    log_name: str,
    digest: str,
    expectation: Expectation,
) -> None:
    """Write a baseline file atomically: readers see the old file or the new one.
    ``log_name`` and ``digest`` (:func:`log_digest`) bind it to its recording."""
    lines = [
        _MAGIC,
        f"# spec {spec_name}",
        f"# log {log_name} sha256 {digest}",
        *map(_draw_line, expectation.draws),
        '#  cycle      time  "behavior": before -> after | output/robot_state "field" = value',
        *format_lines(
            expectation.changes,
            expectation.outputs or (),
            expectation.robot_states,
            expectation.open_loop,
        ),
    ]
    with replacing(path) as file:
        file.write(("\n".join(lines) + "\n").encode())


def _draw_line(rule: DrawRule) -> str:
    recorded, asked = rule.recorded or _NONE, rule.asked or _NONE
    cycles = " ".join(map(str, rule.cycles))
    return f"draws {json.dumps(rule.behavior)}: {recorded} -> {asked} in cycles {cycles}"


def _parse_draw(line: str) -> DrawRule:
    found = _DRAW_LINE.fullmatch(line)
    if found is None:
        raise ValueError("expected 'draws \"behavior\": RECORDED -> ASKED in cycles N N ...'")
    behavior = json.loads(found["behavior"])
    recorded, asked = found["recorded"], found["asked"]
    if recorded == asked:
        raise ValueError(f"a draw of {asked} as recorded is no difference")
    return DrawRule(
        behavior,
        None if recorded == _NONE else recorded,
        None if asked == _NONE else asked,
        tuple(map(int, found["cycles"].split())),
    )


def read_baseline(path: Path) -> Baseline:
    """Read a baseline file; anything else raises :class:`BaselineError` naming the line."""
    problem = irregular_file_problem(path)
    if problem is not None:
        raise BaselineError(path, problem)
    if path.stat().st_size > MAX_BASELINE_BYTES:
        raise BaselineError(path, f"is larger than {MAX_BASELINE_BYTES} bytes; not a baseline")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise BaselineError(path, f"cannot read: {exc}") from None
    lines = text.splitlines()
    version = _VERSIONS.get(lines[0]) if lines else None
    if version is None:
        raise BaselineError(path, "not a beatlog baseline (its first line is not the header)")
    digest = ""
    changes: list[TracedChange] = []
    outputs: list[TracedOutput] = []
    states: list[TracedState] = []
    draws: list[DrawRule] = []
    open_loop: tuple[int, int] | None = None
    for number, line in enumerate(lines[1:], start=2):
        if line.startswith("#"):
            found = _LOG_LINE.fullmatch(line)
            digest = found["digest"] if found else digest
        elif line.strip():
            try:
                parsed = (
                    _parse_draw(line) if line.startswith("draws ") else _parse_line(line, version)
                )
                if isinstance(parsed, DrawRule) and version < 4:
                    raise ValueError(f"a format {version} baseline holds no draws")
            except (ValueError, RecursionError) as exc:
                raise BaselineError(path, f"line {number}: {exc}") from None
            if isinstance(parsed, DrawRule):
                draws.append(parsed)
            elif isinstance(parsed, tuple) and len(parsed) == 2:
                if open_loop is not None:
                    raise BaselineError(path, f"line {number}: a second 'open loop' line")
                open_loop = parsed
            elif isinstance(parsed, TracedOutput):
                outputs.append(parsed)
            elif isinstance(parsed, TracedState):
                states.append(parsed)
            else:
                changes.append(parsed)
    if not digest:
        raise BaselineError(path, "no '# log NAME sha256 DIGEST' line")
    for what, traced in (("output", outputs), ("robot_state", states)):
        cycles = [item.cycle for item in traced]
        if cycles != sorted(cycles):
            raise BaselineError(path, f"{what} lines are not in cycle order")
    pinned = tuple(outputs) if version >= 2 else None
    return Baseline(path, digest, tuple(changes), pinned, tuple(states), tuple(draws), open_loop)


def _parse_line(
    line: str, version: int
) -> TracedChange | TracedOutput | TracedState | tuple[int, int]:
    found = _CHANGE_LINE.fullmatch(line)
    if found is None:
        raise ValueError(
            "expected 'CYCLE TIME \"behavior\": BEFORE -> AFTER', "
            "'CYCLE TIME output \"field\" = VALUE' or 'CYCLE TIME robot_state \"field\" = VALUE'"
        )
    cycle, time_ns, text = int(found["cycle"]), round(float(found["time"]) * 1e9), found["change"]
    if text == _OPEN_LOOP and version >= 4:
        return cycle, time_ns
    if text.startswith(_OUTPUT):
        if version < 2:
            raise ValueError("a format 1 baseline holds no outputs")
        name, value = _parse_value(text[len(_OUTPUT) :])
        return TracedOutput(cycle, time_ns, name, value)
    if text.startswith(_ROBOT_STATE):
        if version < 3:
            raise ValueError(f"a format {version} baseline holds no robot states")
        name, value = _parse_value(text[len(_ROBOT_STATE) :])
        if value is ABSENT:
            raise ValueError("a robot-state field is never absent")
        return TracedState(cycle, time_ns, name, value)
    return TracedChange(cycle, time_ns, _parse_change(text))


def _parse_value(text: str) -> tuple[str, Any]:
    name, end = _JSON.raw_decode(text)
    if not isinstance(name, str):
        raise ValueError("the field must be a JSON string")
    rest = text[end:].rstrip()
    if rest == " absent":
        return name, ABSENT
    end = _expect(text, end, " = ")
    value_text = text[end:].rstrip()
    if value_text.startswith(_MSGPACK):
        try:
            return name, msgspec.msgpack.decode(bytes.fromhex(value_text[len(_MSGPACK) :]))
        except (ValueError, *DECODE_ERRORS) as exc:
            raise ValueError(f"a damaged msgpack value: {exc}") from None
    value, end = _JSON.raw_decode(value_text)
    if end != len(value_text):
        raise ValueError(f"unexpected {value_text[end:]!r} after the value")
    return name, value


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

"""Expected state changes, outputs, robot states and draws approved after an intended change.

Recordings are immutable: when behaviors (or, in sensor-level replay, perception)
change on purpose, the new state changes and outputs go to a *pending* file beside the
spec (``NAME.dtc.pending``), are reviewed, and once approved become the *expected*
file (``NAME.dtc.expected``) that replay judges against instead of the recording.
Both are plain text, one state change or output change a line, and the robot states
perception rebuilds a few characters a cycle, so a re-baseline reads as a diff in
code review::

    # beatlog expected state changes, outputs, robot states and draws, format 4
    # spec avoid-pole
    # log avoid-pole.beatlog sha256 5f0c...
    draws "wander": uniform(0.8, 1.6) -> uniform(0.7, 1.5) in cycles 12 97 240
    draws "escape": - -> uniform(4.0, 8.0) in cycles 12 12
    #  cycle      time  "behavior": before -> after | output "field" = value | ...
           0     0.030  output "speed" = 0.5
          12     0.360  open loop
          12     0.360  robot_state otherwise in 12..16 (3 cycles): ["range"], first {"range": 0.55}
          12     0.360  robot_state digests 5 2757be29f6e5b7d2 WfzB....1Q
          12     0.360  "avoid": "idle" -> "turning"
          12     0.360  output "speed" = 0.0
          40     1.200  output "turn" absent

An output line appears only in the cycles where that field's value changes (cycle 0
gives the initial values); ``absent`` means the field is no longer output. The
robot-state lines pin, for sensor-level replay, the states the perception step
rebuilds otherwise than the recorded RS_t (see :mod:`beatlog.replay.pins`): a line per
run of such cycles (short gaps rebuilt as recorded included) names the fields that
differ and their values in its first cycle, for review; then a line per block of up to
64 of its cycles gives, after the count of cycles, the hex digest of the block and two
base64 characters a cycle, the start of that cycle's digest (``..`` for a cycle in a
gap). Replay judges a pinned cycle's whole rebuilt state by its digest, bit for bit,
and any other cycle against the recording. Behavior names, states and values are
JSON, floats written so they read back bit for bit (``NaN``, ``Infinity``,
``-Infinity``, ``-0.0`` included); a value JSON cannot hold exactly (a NaN with a
payload, bytes) is written as ``msgpack:HEX``, its msgpack encoding. Loading a
baseline never evaluates anything, and a file larger than :data:`MAX_BASELINE_BYTES`
is refused.

A ``draws`` line approves draws that replay makes otherwise than recorded, in the
cycles listed (a cycle once per draw; :mod:`beatlog.replay.draws`): a recorded request
re-mapped to the one asked for now, a new draw (``-`` for the recorded side) or a
recorded one left unused (``-`` for the asked side). A baseline is judged in living
replay, cycle by cycle: any other draw made otherwise, or an approved one not made,
diverges in its cycle. The ``open loop`` line marks the first cycle whose state changes or outputs
leave the recording's: from there the recorded world (RS_t, samples) no longer answers
to what the changed behaviors do, and the session is worth recording again when
convenient. A change that leaves the behaviors' state changes and outputs as
recorded (perception rebuilds other robot states, or draws differ, and the behaviors
do the same) pins neither: the line ``state changes and outputs as recorded`` says
they are judged against the recording.


Format 3 files approve no draws (replay must draw as recorded) and pin robot states a
line per field per cycle, ``12  0.360  robot_state "range" = 0.55``: the recorded state
with these fields is what perception must rebuild, within the spec's tolerances. They
still read and judge so; a new baseline is always written in format 4. Format 2 files
pin no robot states: perception must rebuild the recording. Format 1 files (state
changes only) pin no outputs either, so replay judges outputs against the recording
and says so when they differ; re-approve to pin them.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.errors import BaselineError, NotABeatlogError
from beatlog.files import irregular_file_problem, read_small_text, replacing
from beatlog.log.format import DECODE_ERRORS
from beatlog.replay.draws import DrawRule
from beatlog.replay.expectation import ABSENT, Expectation, TracedChange, TracedOutput, TracedState
from beatlog.replay.pins import DIGEST_BYTES, TAG_CHARS, DigestBlock, PinnedRun, StatePins
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
_COLUMNS = (
    '#  cycle      time  "behavior": before -> after | output "field" = value'
    " | robot_state otherwise in FIRST..LAST (N cycles): [FIELDS], first {VALUES}"
    " | robot_state digests N DIGEST TAGS"
)
_LOG_LINE = re.compile(r"# log (?P<name>.+) sha256 (?P<digest>[0-9a-f]{64})")
_CHANGE_LINE = re.compile(r"\s*(?P<cycle>\d+)\s+(?P<time>\d+\.\d{3})\s+(?P<change>.*)")
_DRAW_LINE = re.compile(
    r'draws (?P<behavior>"(?:[^"\\]|\\.)*"): '
    r"(?P<recorded>.+?) -> (?P<asked>.+) in cycles (?P<cycles>\d+(?: \d+)*)"
)
_NONE = "-"
_OPEN_LOOP = "open loop"
_AS_RECORDED = "state changes and outputs as recorded"
_OUTPUT = "output "
_ROBOT_STATE = "robot_state "
_RUN = re.compile(
    r"otherwise in (?P<first>\d+)\.\.(?P<last>\d+) \((?P<cycles>\d+) cycles?\): (?P<rest>.*)"
)
_RUN_FIRST = ", first "
_DIGESTS = re.compile(
    rf"digests (?P<cycles>\d+) (?P<digest>[0-9a-f]{{{2 * DIGEST_BYTES}}}) (?P<tags>[A-Za-z0-9+/.]+)"
)
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
    state_pins: StatePins = field(default_factory=StatePins)
    """The robot states perception rebuilds otherwise than recorded, by digest (format 4)."""
    draws: tuple[DrawRule, ...] = ()
    """The draws replay may make otherwise than recorded (format 4)."""
    open_loop: tuple[int, int] | None = None
    """Where the behaviors left the recording, when they do (format 4)."""
    as_recorded: bool = False
    """Whether the state changes and outputs are the recording's (format 4)."""

    @property
    def expectation(self) -> Expectation:
        """What replay judges against with this baseline."""
        return Expectation(
            self.changes,
            self.outputs,
            self.robot_states,
            self.state_pins,
            self.draws,
            self.open_loop,
            self.as_recorded,
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
    state_pins: StatePins | None = None,
    open_loop: tuple[int, int] | None = None,
) -> list[str]:
    """The text lines of the pinned robot states, state changes and output changes, by
    cycle, as baseline files hold them: in each cycle in that order, as replay meets
    them, after the line that says the behaviors left the recording there
    (``open_loop``)."""
    keyed = [(s.cycle, 0, _value_line(_ROBOT_STATE, s)) for s in robot_states]
    keyed.extend((cycle, 0, line) for cycle, line in _pin_lines(state_pins or StatePins()))
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


def _pin_lines(pins: StatePins) -> list[tuple[int, str]]:
    """A line per run of pinned robot states, then one per block of their digests: in
    cycle order, each run's line comes before its first block's."""
    lines = []
    for run in pins.runs:
        fields = ", ".join(json.dumps(name) for name in run.fields)
        lines.append(
            (
                run.cycle,
                f"{_columns(run.cycle, run.time_ns)}{_ROBOT_STATE}otherwise in "
                f"{run.cycle}..{run.last} ({run.cycles} cycle{'' if run.cycles == 1 else 's'}): "
                f"[{fields}]{_RUN_FIRST}{_format_value(run.first)}",
            )
        )
    lines.extend(
        (
            block.cycle,
            f"{_columns(block.cycle, block.time_ns)}{_ROBOT_STATE}digests {block.cycles} "
            f"{block.digest.hex()} {block.tags}",
        )
        for block in pins.blocks
    )
    return lines


def _columns(cycle: int, time_ns: int) -> str:
    return f"{cycle:>8} {time_ns / 1e9:>9.3f}  "


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
    ``log_name`` and ``digest`` (:func:`log_digest`) bind it to its recording.

    :raises ValueError: ``expectation`` pins robot-state fields value by value, as only
        format 3 files did: a new baseline pins robot states by digest.
    """
    if expectation.robot_states:
        raise ValueError("format 3 robot-state pins cannot be written: trace the log again")
    lines = [
        _MAGIC,
        f"# spec {spec_name}",
        f"# log {log_name} sha256 {digest}",
        *map(_draw_line, expectation.draws),
        *([_AS_RECORDED] if expectation.as_recorded else []),
        _COLUMNS,
        *format_lines(
            expectation.changes,
            expectation.outputs or (),
            state_pins=expectation.state_pins,
            open_loop=expectation.open_loop,
        ),
    ]
    with replacing(path) as file:
        file.write(("\n".join(lines) + "\n").encode())


def _draw_line(rule: DrawRule) -> str:
    recorded, asked = rule.recorded or _NONE, rule.asked or _NONE
    cycles = " ".join(map(str, rule.cycles))
    return f"draws {json.dumps(rule.behavior)}: {recorded} -> {asked} in cycles {cycles}"


def _parse_draw(line: str, version: int) -> DrawRule:
    if version < 4:
        raise ValueError(f"a format {version} baseline holds no draws")
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
    text = read_small_text(path, limit=MAX_BASELINE_BYTES, kind="baseline", error=BaselineError)
    lines = text.splitlines()
    version = _VERSIONS.get(lines[0]) if lines else None
    if version is None:
        raise BaselineError(path, "not a beatlog baseline (its first line is not the header)")
    digest = ""
    found = _Parsed()
    for number, line in enumerate(lines[1:], start=2):
        if line.startswith("#"):
            log_line = _LOG_LINE.fullmatch(line)
            digest = log_line["digest"] if log_line else digest
        elif line.strip():
            try:
                if line == _AS_RECORDED and version >= 4:
                    found.as_recorded = True
                    continue
                found.add(
                    _parse_draw(line, version)
                    if line[:6] == "draws "
                    else _parse_line(line, version)
                )
            except (ValueError, RecursionError) as exc:
                raise BaselineError(path, f"line {number}: {exc}") from None
    if not digest:
        raise BaselineError(path, "no '# log NAME sha256 DIGEST' line")
    if found.as_recorded and (found.changes or found.outputs or found.open_loop):
        raise BaselineError(
            path, f"'{_AS_RECORDED}', yet it pins state changes, outputs or an open loop"
        )
    for what, traced in (("output", found.outputs), ("robot_state", found.states)):
        cycles = [item.cycle for item in traced]
        if cycles != sorted(cycles):
            raise BaselineError(path, f"{what} lines are not in cycle order")
    try:
        pins = StatePins(tuple(found.runs), tuple(found.blocks))
    except ValueError as exc:
        raise BaselineError(path, str(exc)) from None
    return Baseline(
        path,
        digest,
        tuple(found.changes),
        tuple(found.outputs) if version >= 2 else None,
        tuple(found.states),
        pins,
        tuple(found.draws),
        found.open_loop,
        found.as_recorded,
    )


class _OpenLoop(NamedTuple):
    cycle: int
    time_ns: int


@dataclass
class _Parsed:
    """The lines of a baseline file read so far, by kind."""

    changes: list[TracedChange] = field(default_factory=list)
    outputs: list[TracedOutput] = field(default_factory=list)
    states: list[TracedState] = field(default_factory=list)
    runs: list[PinnedRun] = field(default_factory=list)
    blocks: list[DigestBlock] = field(default_factory=list)
    draws: list[DrawRule] = field(default_factory=list)
    open_loop: tuple[int, int] | None = None
    as_recorded: bool = False

    def add(self, line: _Line) -> None:
        """Keep one parsed line with its kind.

        :raises ValueError: a second ``open loop`` line.
        """
        if isinstance(line, _OpenLoop):
            if self.open_loop is not None:
                raise ValueError("a second 'open loop' line")
            self.open_loop = (line.cycle, line.time_ns)
        elif isinstance(line, DrawRule):
            self.draws.append(line)
        elif isinstance(line, TracedOutput):
            self.outputs.append(line)
        elif isinstance(line, TracedState):
            self.states.append(line)
        elif isinstance(line, PinnedRun):
            self.runs.append(line)
        elif isinstance(line, DigestBlock):
            self.blocks.append(line)
        else:
            self.changes.append(line)


_Line = TracedChange | TracedOutput | TracedState | PinnedRun | DigestBlock | DrawRule | _OpenLoop


def _parse_line(line: str, version: int) -> _Line:
    found = _CHANGE_LINE.fullmatch(line)
    if found is None:
        raise ValueError(
            "expected 'CYCLE TIME \"behavior\": BEFORE -> AFTER', "
            "'CYCLE TIME output \"field\" = VALUE' or 'CYCLE TIME robot_state ...'"
        )
    cycle, time_ns, text = int(found["cycle"]), round(float(found["time"]) * 1e9), found["change"]
    if text == _OPEN_LOOP and version >= 4:
        return _OpenLoop(cycle, time_ns)
    if text.startswith(_OUTPUT):
        if version < 2:
            raise ValueError("a format 1 baseline holds no outputs")
        name, value = _parse_value(text[len(_OUTPUT) :])
        return TracedOutput(cycle, time_ns, name, value)
    if text.startswith(_ROBOT_STATE):
        if version < 3:
            raise ValueError(f"a format {version} baseline holds no robot states")
        if version >= 4:
            return _parse_pin(text[len(_ROBOT_STATE) :], cycle, time_ns)
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
    return name, _decode_value(text[end:].rstrip())


def _decode_value(value_text: str) -> Any:
    """A value as :func:`_format_value` writes it."""
    if value_text.startswith(_MSGPACK):
        try:
            return msgspec.msgpack.decode(bytes.fromhex(value_text[len(_MSGPACK) :]))
        except (ValueError, *DECODE_ERRORS) as exc:
            raise ValueError(f"a damaged msgpack value: {exc}") from None
    value, end = _JSON.raw_decode(value_text)
    if end != len(value_text):
        raise ValueError(f"unexpected {value_text[end:]!r} after the value")
    return value


def _parse_pin(text: str, cycle: int, time_ns: int) -> PinnedRun | DigestBlock:
    """A format 4 robot-state line: a run of pinned cycles, or a block of their digests."""
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
    end = _expect(rest, end, _RUN_FIRST)
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

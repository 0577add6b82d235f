"""A baseline file, written: its header, draws, state changes, outputs, robot states.

Each line of the cycle columns starts with the cycle and its robot time in seconds;
behavior names, states and values are JSON, floats written so they read back bit for
bit, and a value JSON cannot hold exactly is ``msgpack:HEX``
(``docs/reference/baseline-format.md``); :mod:`beatlog.baseline.read` reads it.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import BaselineError
from beatlog.log.files import replacing
from beatlog.replay.approved_states import ApprovedStates
from beatlog.replay.baseline import (
    ABSENT,
    AS_RECORDED,
    Baseline,
    TracedOutput,
    TracedStateChange,
)
from beatlog.replay.draws import ApprovedDraws

__all__ = [
    "AS_RECORDED_TEXT",
    "COLUMNS",
    "COMPRESS_BYTES",
    "FORMAT",
    "HEADER",
    "MSGPACK",
    "NONE",
    "OPEN_LOOP",
    "OUTPUT",
    "QUIET",
    "ROBOT_STATE",
    "RUN_FIRST",
    "draw_line",
    "format_lines",
    "format_value",
    "write_baseline",
]

FORMAT = 7
"""The baseline format written, and the only one read."""
HEADER = f"# beatlog expected departures from the recording, format {FORMAT}"
"""The first line of a baseline file of the current format."""
COMPRESS_BYTES = 1 << 16
"""A baseline whose text is longer is written zstd-compressed: 64 KiB is over a
thousand lines, past what a review reads as a diff, and a change that departs in every
cycle (a retune) writes its lines in about a sixth of the bytes."""

NONE = "-"
"""The side of a draws line with no draw (a new draw, or a recorded one left unused)."""
OPEN_LOOP = "open loop"
QUIET = "no state changes"
"""A cycle whose recorded state changes are gone, none in their place."""
AS_RECORDED_TEXT = "as recorded"
"""An output field that follows the recording again."""
OUTPUT = "output "
ROBOT_STATE = "robot_state "
RUN_FIRST = ", first "
MSGPACK = "msgpack:"
COLUMNS = (
    '#  cycle      time  "behavior": before -> after | no state changes'
    ' | output "field" = value | output "field" absent | output "field" as recorded'
    " | robot_state otherwise in FIRST..LAST (N cycles): [FIELDS], first {VALUES}"
    " | robot_state digests N DIGEST TAGS"
)
"""The comment that heads the cycle columns."""
_SORTED = msgspec.msgpack.Encoder(order="sorted")


def format_lines(
    changes: Iterable[TracedStateChange],
    outputs: Iterable[TracedOutput] | None = None,
    approved_states: ApprovedStates | None = None,
    *,
    open_loop: tuple[int, int] | None = None,
    quiet: Iterable[tuple[int, int]] = (),
) -> list[str]:
    """The text lines of the pinned robot states, state changes and output changes, by
    cycle, as baseline files hold them: in each cycle in that order, as replay meets
    them, after the line that says the behaviors left the recording there
    (``open_loop``). ``quiet`` cycles lost their recorded state changes."""
    keyed = [(cycle, 0, line) for cycle, line in _state_lines(approved_states or ApprovedStates())]
    if open_loop is not None:
        keyed.append((open_loop[0], -1, _columns(*open_loop) + OPEN_LOOP))
    keyed.extend((c.cycle, 1, _change_line(c)) for c in changes)
    keyed.extend((cycle, 1, _columns(cycle, time_ns) + QUIET) for cycle, time_ns in quiet)
    keyed.extend((o.cycle, 2, _output_line(o)) for o in outputs or ())
    keyed.sort(key=lambda item: item[:2])  # stable: the order within a cycle is kept
    return [line for _, _, line in keyed]


def _change_line(traced: TracedStateChange) -> str:
    cycle, time_ns, change = traced
    return (
        f"{_columns(cycle, time_ns)}{json.dumps(change.behavior)}: "
        f"{json.dumps(change.before)} -> {json.dumps(change.after)}"
    )


def _output_line(traced: TracedOutput) -> str:
    cycle, time_ns, name, value = traced
    what = (
        "absent"
        if value is ABSENT
        else AS_RECORDED_TEXT
        if value is AS_RECORDED
        else f"= {format_value(value)}"
    )
    return f"{_columns(cycle, time_ns)}{OUTPUT}{json.dumps(name)} {what}"


def _state_lines(approved: ApprovedStates) -> list[tuple[int, str]]:
    """A line per run of pinned robot states, then one per block of their digests: in
    cycle order, each run's line comes before its first block's."""
    lines = []
    for run in approved.runs:
        fields = ", ".join(json.dumps(name) for name in run.fields)
        lines.append(
            (
                run.cycle,
                f"{_columns(run.cycle, run.time_ns)}{ROBOT_STATE}otherwise in "
                f"{run.cycle}..{run.last} ({run.cycles} cycle{'' if run.cycles == 1 else 's'}): "
                f"[{fields}]{RUN_FIRST}{format_value(run.first)}",
            )
        )
    lines.extend(
        (
            block.cycle,
            f"{_columns(block.cycle, block.time_ns)}{ROBOT_STATE}digests {block.cycles} "
            f"{block.digest.hex()} {block.tags}",
        )
        for block in approved.blocks
    )
    return lines


def _columns(cycle: int, time_ns: int) -> str:
    return f"{cycle:>8} {time_ns / 1e9:>9.3f}  "


def format_value(value: Any) -> str:
    """JSON when it reads back bit for bit, else the msgpack encoding in hex."""
    try:
        text = json.dumps(value, sort_keys=True)
        if _SORTED.encode(json.loads(text)) == _SORTED.encode(value):
            return text
    except (TypeError, ValueError):
        pass
    return MSGPACK + _SORTED.encode(value).hex()


def draw_line(rule: ApprovedDraws) -> str:
    """``draws "wander": uniform(0.8, 1.6) -> uniform(0.7, 1.5) in cycles 12 97``."""
    recorded, asked = rule.recorded or NONE, rule.asked or NONE
    cycles = " ".join(map(str, rule.cycles))
    return f"draws {json.dumps(rule.behavior)}: {recorded} -> {asked} in cycles {cycles}"


def write_baseline(
    path: Path,
    *,
    spec_name: str,
    log_name: str,
    digest: str,
    baseline: Baseline,
) -> None:
    """Write a baseline file atomically: readers see the old file or the new one.
    ``log_name`` and ``digest`` (:func:`~beatlog.baseline.file.log_digest`) bind it to
    its recording. Text longer than :data:`COMPRESS_BYTES` is written as a zstd frame.

    :raises BaselineError: the file cannot be written (a full disk): the old file, if
        any, stays whole.
    """
    lines = [
        HEADER,
        f"# spec {spec_name}",
        f"# log {log_name} sha256 {digest}",
        *map(draw_line, baseline.draws),
        COLUMNS,
        *format_lines(
            baseline.changes,
            baseline.outputs or (),
            approved_states=baseline.approved_states,
            open_loop=baseline.open_loop,
            quiet=baseline.quiet,
        ),
    ]
    text = ("\n".join(lines) + "\n").encode()
    if len(text) > COMPRESS_BYTES:
        import zstandard  # noqa: PLC0415 - only a long baseline needs it

        # Written once and read often: up to a megabyte (half a second) as small as zstd
        # makes it, a bigger one at zstd's default level, its speed (some 100 MB a second).
        level = 19 if len(text) <= 1 << 20 else 3
        text = zstandard.ZstdCompressor(level=level).compress(text)
    try:
        with replacing(path) as file:
            file.write(text)
    except OSError as exc:
        raise BaselineError(path, f"cannot write: {exc.strerror or exc}") from None

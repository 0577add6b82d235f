"""Approved baselines: where replay may depart from the recording after an intended change.

Recordings are immutable: when behaviors (or, in sensor-level replay, perception)
change on purpose, the new state changes and outputs go to a *pending* file beside the
spec (``NAME.dtc.pending``), are reviewed, and once approved become the *expected*
file (``NAME.dtc.expected``) that replay judges against instead of the recording.
The recording is always beside it, so a baseline holds only where the behaviors
depart from it (:mod:`beatlog.replaying.departures`), in plain text, a state change or
output a line, and the robot states perception rebuilds a few characters a cycle: a
re-baseline reads as a diff in code review::

    # beatlog expected departures from the recording, format 6
    # spec avoid-pole
    # log avoid-pole.beatlog sha256 5f0c...
    draws "wander": uniform(0.8, 1.6) -> uniform(0.7, 1.5) in cycles 12 97 240
    draws "escape": - -> uniform(4.0, 8.0) in cycles 12 12
    #  cycle      time  "behavior": before -> after | no state changes | output ...
          12     0.360  open loop
          12     0.360  robot_state otherwise in 12..16 (3 cycles): ["range"], first {"range": 0.55}
          12     0.360  robot_state digests 5 45b024220a80a3e9 Zsc2....aF
          12     0.360  "avoid": "idle" -> "turning"
          12     0.360  output "speed" = 0.0
          30     0.900  no state changes
          40     1.200  output "turn" absent
          52     1.560  output "speed" as recorded

A cycle with state-change lines has those state changes instead of the recorded ones;
``no state changes`` says the recorded ones are gone and none stand in; any other
cycle's are as recorded. An output line gives a field the value it holds from that
cycle on, whatever was recorded (``absent``: the field is not output), until ``as
recorded`` gives it back to the recording. So the lines start at the cycle the
``open loop`` line names, the first where the behaviors leave the recording: from
there the recorded world (RS_t, samples) no longer answers to what the changed
behaviors do, and the session is worth recording again when convenient. A change the
behaviors do not notice (perception rebuilds other robot states, draws differ to no
effect) has no such lines.

The robot-state lines pin, for sensor-level replay, the states the perception step
rebuilds otherwise than the recorded RS_t (see :mod:`beatlog.replaying.pins`): a line per
run of such cycles (short gaps rebuilt as recorded included) names the fields that
differ and their values in its first cycle, for review; then a line per block of up to
64 of its cycles gives, after the count of cycles, the hex digest of the block and two
base64 characters a cycle, the start of that cycle's digest (``..`` for a cycle in a
gap): XXH64 of the state as the log encodes it
(:func:`~beatlog.replaying.state_digests.state_digest`), and of its pinned cycles'
digests end to end for the block. Replay judges a pinned cycle's whole rebuilt state
by its digest, bit for bit, and any other cycle against the recording. Behavior names,
states and values are JSON, floats written so they read back bit for bit (``NaN``, ``Infinity``,
``-Infinity``, ``-0.0`` included); a value JSON cannot hold exactly (a NaN with a
payload, bytes) is written as ``msgpack:HEX``, its msgpack encoding. Loading a
baseline never evaluates anything, and a file larger than :data:`MAX_BASELINE_BYTES`
is refused.

A ``draws`` line approves draws that replay makes otherwise than recorded, in the
cycles listed (a cycle once per draw; :mod:`beatlog.replaying.draws`): a recorded request
re-mapped to the one asked for now, a new draw (``-`` for the recorded side) or a
recorded one left unused (``-`` for the asked side). A baseline is judged in living
replay, cycle by cycle: any other draw made otherwise, or an approved one not made,
diverges in its cycle.

A baseline is read in this format alone: a file of an older one is refused, naming
the command that rewrites it in this one (:mod:`beatlog.baseline.upgrade`).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

from beatlog.baseline.read import ParsedLines, line_feeds
from beatlog.baseline.write import HEADER
from beatlog.errors import BaselineError, NotABeatlogError
from beatlog.log.files import irregular_file_problem, read_text_blocks
from beatlog.replaying.expectation import Expectation
from beatlog.replaying.pins import StatePins

__all__ = [
    "BLOCK_BYTES",
    "EXPECTED_SUFFIX",
    "MAX_BASELINE_BYTES",
    "OLD_HEADERS",
    "PENDING_SUFFIX",
    "SPEC_SUFFIX",
    "Baseline",
    "expected_path",
    "log_digest",
    "pending_path",
    "read_baseline",
    "spec_path",
    "upgrade_hint",
]

SPEC_SUFFIX = ".dtc.toml"
"""How a DTC spec's file name ends; its baselines are named after it."""

EXPECTED_SUFFIX = ".dtc.expected"
PENDING_SUFFIX = ".dtc.pending"
MAX_BASELINE_BYTES = 1 << 28
"""A baseline is a line per change; a file bigger than this is not one."""
BLOCK_BYTES = 1 << 20
"""How much of a baseline is read at a time: reading holds a block of its text, and
what its lines read to, not the whole file's text."""
OLD_HEADERS = {
    "# beatlog expected departures from the recording, format 5": 5,
    "# beatlog expected state changes, outputs, robot states and draws, format 4": 4,
    "# beatlog expected state changes, outputs and robot states, format 3": 3,
    "# beatlog expected state changes and outputs, format 2": 2,
    "# beatlog expected state changes, format 1": 1,
}
"""The first lines of the older formats, each with its number: read only to upgrade."""
UPGRADE_COMMAND = "beatlog upgrade-baselines"
_LOG_LINE = re.compile(r"# log (?P<name>.+) sha256 (?P<digest>[0-9a-f]{64})")
_NOT_A_BASELINE = "not a beatlog baseline (its first line is not the header)"


@dataclass(frozen=True)
class Baseline:
    """A baseline file: the recording it was made from and what replay judges against."""

    path: Path
    log_digest: str
    """The SHA-256 of the recording (:func:`log_digest`)."""
    expectation: Expectation


def _base(spec: Path) -> str:
    name = spec.name
    return name[: -len(SPEC_SUFFIX)] if name.endswith(SPEC_SUFFIX) else spec.stem


def expected_path(spec: Path) -> Path:
    """Where the approved baseline of the spec at ``spec`` lives."""
    return spec.with_name(_base(spec) + EXPECTED_SUFFIX)


def pending_path(spec: Path) -> Path:
    """Where the pending (not yet approved) baseline of the spec at ``spec`` lives."""
    return spec.with_name(_base(spec) + PENDING_SUFFIX)


def spec_path(baseline: Path) -> Path:
    """The spec an approved or pending baseline at ``baseline`` belongs to."""
    name = baseline.name
    for suffix in (EXPECTED_SUFFIX, PENDING_SUFFIX):
        if name.endswith(suffix):
            return baseline.with_name(name[: -len(suffix)] + SPEC_SUFFIX)
    return baseline.with_suffix(SPEC_SUFFIX)


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


def upgrade_hint(path: Path, version: int) -> str:
    """What an older baseline's error says: its format, and the command that rewrites it."""
    return f"a format {version} baseline: run '{UPGRADE_COMMAND} {path}' to rewrite it in format 6"


def read_baseline(path: Path) -> Baseline:
    """Read a baseline file, a block of lines at a time (:data:`BLOCK_BYTES`); anything
    else, a file of an older format included, raises :class:`BaselineError` naming the
    line (or the command that upgrades it)."""
    started = False
    number = 1
    digest = ""
    found = ParsedLines()
    for block in read_text_blocks(
        path,
        limit=MAX_BASELINE_BYTES,
        kind="baseline",
        error=BaselineError,
        block_bytes=BLOCK_BYTES,
    ):
        text, count = line_feeds(block)
        if not started:
            first, _, text = text.partition("\n")
            if first in OLD_HEADERS:
                raise BaselineError(path, upgrade_hint(path, OLD_HEADERS[first]))
            if first != HEADER:
                raise BaselineError(path, _NOT_A_BASELINE)
            started, number, count = True, 2, count - 1
        for at, line in found.read_common(text, start=number):
            if line.startswith("#"):
                log_line = _LOG_LINE.fullmatch(line)
                digest = log_line["digest"] if log_line else digest
            elif line.strip():
                try:
                    found.add(line)
                except (ValueError, RecursionError) as exc:
                    raise BaselineError(path, f"line {at}: {exc}") from None
        number += count
    if not started:  # an empty file
        raise BaselineError(path, _NOT_A_BASELINE)
    if not digest:
        raise BaselineError(path, "no '# log NAME sha256 DIGEST' line")
    return Baseline(path, digest, _expectation(path, found))


def _expectation(path: Path, found: ParsedLines) -> Expectation:
    """What the lines of a baseline file expect.

    :raises BaselineError: lines out of cycle order, a cycle both quiet and with
        state changes, or robot-state pins that do not hold together.
    """
    for what, traced in (("output", found.outputs), ("state change", found.changes)):
        cycles = [item.cycle for item in traced]
        if cycles != sorted(cycles):
            raise BaselineError(path, f"{what} lines are not in cycle order")
    both = {cycle for cycle, _ in found.quiet} & {change.cycle for change in found.changes}
    if both:
        raise BaselineError(path, f"cycle {min(both)} has state changes and none")
    try:
        pins = StatePins(tuple(found.runs), tuple(found.blocks))
    except ValueError as exc:
        raise BaselineError(path, str(exc)) from None
    return Expectation(
        tuple(found.changes),
        tuple(found.outputs),
        pins,
        tuple(found.draws),
        found.open_loop,
        tuple(found.quiet),
    )

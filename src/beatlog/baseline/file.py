"""Approved baselines: where replay may depart from the recording after an intended change.

Recordings are immutable: when behaviors (or, in sensor-level replay, perception)
change on purpose, the new departures go to a *pending* file beside the spec
(``NAME.dtc.pending``), are reviewed, and once approved become the *expected* file
(``NAME.dtc.expected``) that replay judges against instead of the recording. A baseline
is plain text, a line per departure (a state change, an output, draws made otherwise,
robot states perception rebuilds, pinned by digest), so a re-baseline reads as a diff
in code review; a long one is one zstd frame of that text. Loading a baseline never
evaluates anything. ``docs/reference/baseline-format.md`` is the full specification.

A baseline is read in this format alone: a file of an older one is refused, naming
the command that rewrites it in this one (:mod:`beatlog.baseline.upgrade`).
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from beatlog.baseline.digests import DigestCoverage
from beatlog.baseline.read import ParsedLines, line_feeds
from beatlog.baseline.write import FORMAT, HEADER, QUIET
from beatlog.errors import BaselineError, NotABeatlogError
from beatlog.log.files import check_size, irregular_file_problem
from beatlog.replay.approved_states import ApprovedStates
from beatlog.replay.baseline import (
    Baseline,
    BaselinePart,
    BaselineStream,
)
from beatlog.replay.draws import ApprovedDraws

__all__ = [
    "BLOCK_BYTES",
    "EXPECTED_SUFFIX",
    "MAX_BASELINE_BYTES",
    "OLD_HEADERS",
    "PENDING_SUFFIX",
    "SPEC_SUFFIX",
    "ZSTD_MAGIC",
    "BaselineFile",
    "expected_path",
    "log_digest",
    "pending_path",
    "read_baseline",
    "spec_path",
    "text_blocks",
]

SPEC_SUFFIX = ".dtc.toml"
"""How a DTC spec's file name ends; its baselines are named after it."""

EXPECTED_SUFFIX = ".dtc.expected"
PENDING_SUFFIX = ".dtc.pending"
MAX_BASELINE_BYTES = 1 << 28
"""A baseline is a line per change; a file bigger than this is not one."""
ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
"""How a zstd frame starts: a baseline that does is the text it holds, compressed."""
BLOCK_BYTES = 1 << 20
"""How much of a baseline is read at a time: reading holds a block of its text, and
what its lines read to, not the whole file's text."""
OLD_HEADERS = {
    "# beatlog expected departures from the recording, format 6": 6,
    "# beatlog expected departures from the recording, format 5": 5,
    "# beatlog expected state changes, outputs, robot states and draws, format 4": 4,
    "# beatlog expected state changes, outputs and robot states, format 3": 3,
    "# beatlog expected state changes and outputs, format 2": 2,
    "# beatlog expected state changes, format 1": 1,
}
"""The first lines of the older formats, each with its number: read only to upgrade."""
_LOG_LINE = re.compile(r"# log (?P<name>.+) sha256 (?P<digest>[0-9a-f]{64})")
_NOT_A_BASELINE = "not a beatlog baseline (its first line is not the header)"
_KINDS = ("output", "state change", f"'{QUIET}'")
"""The kinds of lines each in cycle order, as errors name them."""


@dataclass(frozen=True)
class BaselineFile:
    """A baseline file, read: the recording it was made from and the baseline it holds,
    as replay reads it (:attr:`stream`) or whole (:attr:`whole`): the lines of cycles of
    a file longer than a block are read from it each time they are asked for, so the
    file must stay where it is."""

    path: Path
    log_digest: str
    """The SHA-256 of the recording (:func:`log_digest`)."""
    stream: BaselineStream
    """The baseline as replay reads it: the lines of cycles of a file of one block as read, a
    longer file's read afresh a block at a time, so replay holds no more of it than a
    block."""

    @property
    def whole(self) -> Baseline:
        """The whole baseline, in memory (for a review, a diff)."""
        parts = list(self.stream.parts())
        chain = itertools.chain.from_iterable
        return Baseline(
            tuple(chain(part.changes for part in parts)),
            tuple(chain(part.outputs for part in parts)),
            ApprovedStates(
                tuple(chain(p.runs for p in parts)), tuple(chain(p.blocks for p in parts))
            ),
            self.stream.draws,
            self.stream.open_loop,
            tuple(chain(part.quiet for part in parts)),
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
    try:
        with log.open("rb") as file:
            return hashlib.file_digest(file, "sha256").hexdigest()
    except OSError as exc:
        raise BaselineError(log, f"cannot read: {exc.strerror or exc}") from None


def text_blocks(path: Path) -> Iterator[str]:
    """The text of the baseline file at ``path`` in blocks of whole lines of about
    :data:`BLOCK_BYTES`, so that a long one is read in bounded memory; a file of zstd
    frames is read as the text they hold, refused once it holds more than
    :data:`MAX_BASELINE_BYTES`."""
    limit = MAX_BASELINE_BYTES
    check_size(path, limit=limit, kind="baseline", error=BaselineError)
    read = 0
    damaged: tuple[type[Exception], ...] = ()
    try:
        with path.open("rb") as raw:
            file: IO[bytes] = raw
            if raw.read(len(ZSTD_MAGIC)) == ZSTD_MAGIC:
                import zstandard  # noqa: PLC0415 - only a compressed baseline needs it

                damaged = (zstandard.ZstdError,)
                file = zstandard.ZstdDecompressor().stream_reader(raw, read_across_frames=True)
            raw.seek(0)
            rest = b""
            while block := file.read(BLOCK_BYTES):
                if read + len(rest) + len(block) > limit:
                    raise BaselineError(
                        path, f"holds more than {limit} bytes of text; not a baseline"
                    )
                end = block.rfind(b"\n") + 1
                if not end:  # a line longer than a block: read on to its end
                    rest += block
                    continue
                text, rest = rest + block[:end], block[end:]
                yield text.decode("utf-8")
                read += len(text)
            if rest:
                yield rest.decode("utf-8")
    except OSError as exc:
        raise BaselineError(path, f"cannot read: {exc}") from None
    except UnicodeDecodeError as exc:
        raise BaselineError(
            path, f"cannot read: {exc.reason} at byte {read + exc.start} (not UTF-8 text)"
        ) from None
    except damaged as exc:
        raise BaselineError(path, f"cannot read: damaged zstd data ({exc})") from None


def read_baseline(path: Path) -> BaselineFile:
    """Read and check a baseline file, a block of lines at a time (:data:`BLOCK_BYTES`),
    keeping what applies to the whole session, and the lines of cycles of a file of one
    block as read; a longer file's are read again, the same way, as replay needs them
    (:attr:`BaselineFile.stream`). Anything else, a file of an older format included,
    raises :class:`BaselineError` naming the line (or the command that upgrades it)."""
    reading = _Reading(path)
    draws: list[ApprovedDraws] = []
    departs = pinned = False
    behaviors: dict[str, None] = {}
    kept: list[BaselinePart] | None = []  # the first block's lines, while it is the only one
    for found in reading.parts():
        draws.extend(found.draws)
        departs = departs or bool(found.changes or found.quiet or found.outputs)
        pinned = pinned or bool(found.blocks)
        behaviors.update(dict.fromkeys(traced.change.behavior for traced in found.changes))
        kept = [_part(found)] if kept == [] else None
    stream = BaselineStream(
        tuple(draws),
        reading.open_loop,
        departs=departs,
        pinned=pinned,
        behaviors=tuple(behaviors),
        parts=functools.partial(_parts, path, frozenset(behaviors))
        if kept is None
        else functools.partial(iter, kept),
    )
    return BaselineFile(path, reading.digest, stream)


def _part(found: ParsedLines) -> BaselinePart:
    return BaselinePart(found.changes, found.quiet, found.outputs, found.runs, found.blocks)


def _parts(path: Path, behaviors: frozenset[str]) -> Iterator[BaselinePart]:
    """The lines of cycles of the baseline at ``path``, read and checked a block at a
    time; their state changes name only ``behaviors``, as when it was first read.

    :raises BaselineError: a line does not read, breaks the format's rules, or the file
        changed since it was first read.
    """
    for found in _Reading(path).parts():
        if not {traced.change.behavior for traced in found.changes} <= behaviors:
            raise BaselineError(path, "changed while it was read: run again")
        yield _part(found)


class _Reading:
    """A baseline file read a block of lines at a time, each block's lines checked
    against the rules of the format as they are read, and those before."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.digest = ""
        """The log's digest, from the ``# log`` line."""
        self.open_loop: tuple[int, int] | None = None
        self._coverage = DigestCoverage()
        self._last = -1
        """The last cycle of the lines read."""
        self._lasts = [-1, -1, -1]
        """The last cycle of each kind of line read (:data:`_KINDS`)."""

    def parts(self) -> Iterator[ParsedLines]:
        """The lines of each block, read and checked.

        :raises BaselineError: a line does not read, or breaks the format's rules.
        """
        path = self.path
        started = False
        number = 1
        for block in text_blocks(path):
            text, count = line_feeds(block)
            if not started:
                first, _, text = text.partition("\n")
                if first in OLD_HEADERS:
                    raise BaselineError(
                        path,
                        f"a format {OLD_HEADERS[first]} baseline: run 'beatlog upgrade-baselines "
                        f"{path}' to rewrite it in format {FORMAT}",
                    )
                if first != HEADER:
                    raise BaselineError(path, _NOT_A_BASELINE)
                started, number, count = True, 2, count - 1
            found = ParsedLines()
            for at, line in found.read_common(text, start=number):
                if line.startswith("#"):
                    log_line = _LOG_LINE.fullmatch(line)
                    self.digest = log_line["digest"] if log_line else self.digest
                elif line.strip():
                    try:
                        found.add(line)
                    except (ValueError, RecursionError) as exc:
                        raise BaselineError(path, f"line {at}: {exc}") from None
            number += count
            self._check(found)
            yield found
        if not started:  # an empty file
            raise BaselineError(path, _NOT_A_BASELINE)
        if not self.digest:
            raise BaselineError(path, "no '# log NAME sha256 DIGEST' line")
        problem = self._coverage.end()
        if problem is not None:
            raise BaselineError(path, problem)

    def _check(self, found: ParsedLines) -> None:
        """Check a block's lines against the format's rules, and those before them.

        :raises BaselineError: lines out of cycle order, a cycle both quiet and with
            state changes, a second ``open loop`` line, or approved robot states that do not
            hold together.
        """
        path = self.path
        if found.open_loop is not None:
            if self.open_loop is not None:
                raise BaselineError(path, "a second 'open loop' line")
            self.open_loop = found.open_loop
        lasts = self._lasts
        listed = (
            [traced.cycle for traced in found.outputs],
            [traced.cycle for traced in found.changes],
            [cycle for cycle, _ in found.quiet],
        )
        for what, cycles, last in zip(_KINDS, listed, lasts, strict=True):
            if cycles != sorted(cycles) or (cycles and cycles[0] < last):
                raise BaselineError(path, f"{what} lines are not in cycle order")
        _, changes, quiet = listed
        both = set(quiet) & {*changes, lasts[1]} | set(changes) & {lasts[2]}
        if both:
            raise BaselineError(path, f"cycle {min(both)} has state changes and none")
        firsts = [cycles[0] for cycles in listed if cycles]
        firsts.extend(kind[0].cycle for kind in (found.runs, found.blocks) if kind)
        if min(firsts, default=self._last) < self._last:
            raise BaselineError(path, f"the lines of cycle {min(firsts)} are not in cycle order")
        self._lasts = [
            cycles[-1] if cycles else last for cycles, last in zip(listed, lasts, strict=True)
        ]
        self._last = max(self._last, _part(found).last)
        problem = self._coverage.add(found.runs, found.blocks)
        if problem is not None:
            raise BaselineError(path, problem)

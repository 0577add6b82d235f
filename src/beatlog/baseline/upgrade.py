"""Baselines of older formats rewritten in the current one: the one place they are read
(``docs/reference/baseline-format.md`` says what each held).

Format 5 and 6 files hold format 7's lines under another first line. Formats 1 to 4
held the whole trace of state changes and outputs: the recording its ``# log`` line
names, bound by its digest, turns that into its departures. Robot states pinned before
format 6 are not translated (only perception rebuilding them gives their digests): such
a file is refused, to be re-approved from its recording. A file is rewritten
atomically, and only once it reads back in the current format.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from beatlog.analysis.trace import recorded_outputs, recorded_trace
from beatlog.baseline.file import (
    EXPECTED_SUFFIX,
    OLD_HEADERS,
    PENDING_SUFFIX,
    SPEC_SUFFIX,
    expected_path,
    log_digest,
    pending_path,
    read_baseline,
    text_blocks,
)
from beatlog.baseline.write import HEADER, OUTPUT, QUIET, ROBOT_STATE, write_baseline
from beatlog.errors import BaselineError
from beatlog.log.files import replacing
from beatlog.replay.baseline import AS_RECORDED, Baseline, TracedOutput, TracedStateChange
from beatlog.replay.departures import OutputDepartures

__all__ = ["Recordings", "Upgraded", "baseline_files", "upgrade_baseline", "upgrade_baselines"]

Recordings = Callable[[Path, str], Path]
"""Where the recording of a baseline is, given the baseline's path and the log name its
``# log`` line gives (the spec beside it says; the shells know how to read one)."""

_AS_RECORDED = "state changes and outputs as recorded"
"""A format 4 line: the behaviors' state changes and outputs are the recording's."""
_RE_APPROVE = "re-approve it from its recording ('beatlog test --update', then 'beatlog approve')"


class Upgraded(NamedTuple):
    """A baseline file rewritten in the current format, and the format it had."""

    path: Path
    version: int


def baseline_files(paths: Iterable[Path]) -> list[Path]:
    """The approved and pending baselines given: files as they are, a spec's beside it,
    and those under folders."""
    found: list[Path] = []
    for path in paths:
        if path.name.endswith(SPEC_SUFFIX):
            beside = (expected_path(path), pending_path(path))
            found.extend(file for file in beside if file.exists())
        elif path.is_dir():
            found.extend(
                sorted(
                    file
                    for suffix in (EXPECTED_SUFFIX, PENDING_SUFFIX)
                    for file in path.rglob(f"*{suffix}")
                )
            )
        else:
            found.append(path)
    return found


def beside(baseline: Path, log_name: str) -> Path:
    """The recording named ``log_name`` in the baseline's folder."""
    return baseline.with_name(log_name)


def upgrade_baselines(paths: Sequence[Path], recordings: Recordings = beside) -> list[Upgraded]:
    """Rewrite in the current format every baseline of an older format among ``paths``
    (files, or folders searched for ``*.dtc.expected`` and ``*.dtc.pending``); those of
    the current format are left as they are. ``recordings`` finds the recording a whole
    trace departs from.

    :raises BaselineError: a file is no baseline, is damaged, or cannot be upgraded
        (the files before it are upgraded, it and those after are left as they were).
    """
    upgrades = (upgrade_baseline(path, recordings) for path in baseline_files(paths))
    return [upgraded for upgraded in upgrades if upgraded]


def upgrade_baseline(path: Path, recordings: Recordings = beside) -> Upgraded | None:
    """Rewrite a baseline of an older format in the current one; None if it is of the
    current format already (it is read whole, so damage is still refused)."""
    text = "".join(text_blocks(path))
    first, _, body = text.partition("\n")
    version = OLD_HEADERS.get(first)
    if version is None:
        read_baseline(path)  # the current format (or refused as no baseline, naming the line)
        return None
    lines = body.splitlines()
    if version < 6 and any(_columns_of(line).startswith(ROBOT_STATE) for line in lines):
        raise BaselineError(
            path, f"its robot states are pinned as format {version} pinned them: {_RE_APPROVE}"
        )
    as_recorded = version == 4 and _AS_RECORDED in lines
    translated = "\n".join([HEADER, *(line for line in lines if line != _AS_RECORDED)]) + "\n"
    scratch = path.with_name(path.name + ".upgrading")
    try:
        with replacing(scratch) as file:
            file.write(translated.encode())
        read = read_baseline(scratch)
        baseline = read.whole  # read whole before the scratch file goes
    except BaselineError as exc:
        raise BaselineError(path, exc.problem.replace(str(scratch), str(path))) from None
    finally:
        scratch.unlink(missing_ok=True)
    spec_name, log_name = _names(lines)
    if version < 5 and not as_recorded:
        log = recordings(path, log_name)
        if not log.is_file() or log_digest(log) != read.log_digest:
            raise BaselineError(path, f"its recording {log} is not as it was: {_RE_APPROVE}")
        baseline = _departures(path, version, log, baseline)
    elif as_recorded and (
        baseline.changes or baseline.outputs or baseline.open_loop or baseline.quiet
    ):
        raise BaselineError(
            path, f"'{_AS_RECORDED}', yet it pins state changes, outputs or an open loop"
        )
    write_baseline(
        path,
        spec_name=spec_name,
        log_name=log_name,
        digest=read.log_digest,
        baseline=baseline,
    )
    return Upgraded(path, version)


def _columns_of(line: str) -> str:
    """What a line of the cycle columns says after its cycle and time."""
    parts = line.split(maxsplit=2)
    return parts[2] if len(parts) == 3 and parts[0].isdecimal() else ""


def _names(lines: Sequence[str]) -> tuple[str, str]:
    """The spec and log names the ``# spec`` and ``# log`` lines give."""
    spec = next((line[len("# spec ") :] for line in lines if line.startswith("# spec ")), "")
    log = next((line[len("# log ") :] for line in lines if line.startswith("# log ")), "")
    return spec, log.rpartition(" sha256 ")[0]


def _departures(path: Path, version: int, log: Path, whole: Baseline) -> Baseline:
    """Where a whole trace of format ``version`` departs from the recording ``log``."""
    if whole.quiet or any(line.value is AS_RECORDED for line in whole.outputs or ()):
        said = QUIET if whole.quiet else f"{OUTPUT}... as recorded"
        raise BaselineError(path, f"a format {version} baseline holds no '{said.strip()}' lines")
    changes, quiet = _change_departures(whole.changes, recorded_trace(log))
    outputs: tuple[TracedOutput, ...] = ()
    if version >= 2:
        outputs = _output_departures(whole.outputs or (), recorded_outputs(log))
    starts = [*quiet, *((c.cycle, c.time_ns) for c in changes)]
    starts.extend((line.cycle, line.time_ns) for line in outputs)
    return dataclasses.replace(
        whole, changes=changes, outputs=outputs, quiet=quiet, open_loop=min(starts, default=None)
    )


def _change_departures(
    whole: Sequence[TracedStateChange], recorded: Sequence[TracedStateChange]
) -> tuple[tuple[TracedStateChange, ...], tuple[tuple[int, int], ...]]:
    """The cycles whose state changes in ``whole`` are not the recorded ones (as a set):
    the trace's, or quiet where it has none."""
    mine = _by_cycle(whole)
    theirs = _by_cycle(recorded)
    changes: list[TracedStateChange] = []
    quiet: list[tuple[int, int]] = []
    for cycle in sorted(mine.keys() | theirs.keys()):
        here, there = mine.get(cycle, []), theirs.get(cycle, [])
        if {_key(traced) for traced in here} == {_key(traced) for traced in there}:
            continue
        if here:
            changes.extend(here)
        else:
            quiet.append((cycle, there[0].time_ns))
    return tuple(changes), tuple(quiet)


def _by_cycle(traced: Iterable[TracedStateChange]) -> dict[int, list[TracedStateChange]]:
    grouped: dict[int, list[TracedStateChange]] = {}
    for line in traced:
        grouped.setdefault(line.cycle, []).append(line)
    return grouped


def _key(traced: TracedStateChange) -> tuple[str, str, str]:
    change = traced.change
    return change.behavior, json.dumps(change.before), json.dumps(change.after)


def _output_departures(
    whole: Sequence[TracedOutput], recorded: Sequence[TracedOutput]
) -> tuple[TracedOutput, ...]:
    """The output lines of departures: where a field of the trace's outputs holds another
    value than the recorded one (both as compact changes), or follows it again."""
    mine = dict(Baseline((), tuple(whole)).outputs_by_cycle())
    theirs = dict(Baseline((), tuple(recorded)).outputs_by_cycle())
    times = {line.cycle: line.time_ns for line in (*whole, *recorded)}
    departures = OutputDepartures()
    held: dict[str, Any] = {}
    was: dict[str, Any] = {}
    lines: list[TracedOutput] = []
    for cycle in sorted(mine.keys() | theirs.keys()):
        held, was = mine.get(cycle, held), theirs.get(cycle, was)
        lines.extend(departures.observe(cycle, times[cycle], was, held))
    return tuple(lines)

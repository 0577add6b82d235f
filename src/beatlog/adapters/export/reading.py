"""Reading a session log for export: its cycles decoded with behaviors and actors by
name, a first read that types what the header does not declare, and the metadata every
export carries."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.adapters.export.declared import declared_object
from beatlog.adapters.export.fields import (
    Field,
    add_types,
    find_non_finite_arrays,
    holds_number_arrays,
    inferred,
    merged,
    typed_object,
)
from beatlog.errors import CorruptLogError, ExportError
from beatlog.log.format import (
    DECODE_ERRORS,
    EMPTY_LIST,
    Draw,
    SessionHeader,
    StateChangeRecord,
)
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.behavior import BehaviorState
from beatlog.model.inbox import Sample
from beatlog.replaying.verdict import StateChange

__all__ = [
    "Cycle",
    "FirstRead",
    "Session",
    "decoded_cycles",
    "first_read",
    "log_metadata",
    "replacing_output",
    "states_after",
]


class Cycle(NamedTuple):
    """One cycle of the log, decoded, with behaviors and actors by name."""

    number: int
    time_ns: int
    heartbeat_ns: int
    robot_state: dict[str, Any]
    changes: list[StateChange]
    draws: list[tuple[str, Draw]]
    outputs: dict[str, Any]
    samples: list[Sample]


class FirstRead(NamedTuple):
    """What a first pass over the log finds."""

    initial: Mapping[str, BehaviorState]
    """Each catalogue behavior's state at the start: the ``before`` of its first change
    (None for a behavior that never changes in the log)."""
    output_types: Mapping[str, str | None]
    """Each output's JSON-schema type over the whole log (see ``add_types``)."""
    status: LogStatus
    """How the log ends."""
    robot_state: Field
    """The robot state's fields: as the header declares them, else as the log holds them."""
    non_finite_arrays: frozenset[str]
    """The robot-state arrays of numbers that hold a NaN or ±inf somewhere in the log, as
    paths (``ranges``, ``pose.cov``, ``blips[].values``)."""
    samples: Mapping[str, Field | None]
    """Each sensor's sample values as the log holds them (None: only nulls)."""


class Session(NamedTuple):
    """What the writers read: the log, its header, its cycles decoded one by one, and
    what a first read of the log found."""

    log: Path
    header: SessionHeader
    cycles: Iterator[Cycle]
    first: FirstRead


def decoded_cycles(reader: SessionLogReader) -> Iterator[Cycle]:
    names = reader.header.behaviors
    decode_map = msgspec.msgpack.Decoder(dict[str, Any]).decode
    decode_changes = msgspec.msgpack.Decoder(list[StateChangeRecord]).decode
    decode_draws = msgspec.msgpack.Decoder(list[Draw]).decode
    decode_samples = msgspec.msgpack.Decoder(list[Sample]).decode
    time_ns = 0
    for number, record in enumerate(reader.cycles()):
        time_ns += record.heartbeat_ns
        try:
            state = decode_map(record.robot_state)
            changes = (
                [] if record.state_changes == EMPTY_LIST else decode_changes(record.state_changes)
            )
            draws = (
                [] if record.random_numbers == EMPTY_LIST else decode_draws(record.random_numbers)
            )
            outputs = decode_map(record.outputs)
            samples = [] if record.samples == EMPTY_LIST else decode_samples(record.samples)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(reader.path, f"damaged cycle {number}: {exc}") from None
        yield Cycle(
            number,
            time_ns,
            record.heartbeat_ns,
            state,
            [StateChange(_name(names, index), before, after) for index, before, after in changes],
            [(_name(names, draw.actor), draw) for draw in draws],
            outputs,
            samples,
        )


def _name(catalogue: Sequence[str], index: int) -> str:
    if index < 0:
        return "system"
    return catalogue[index] if index < len(catalogue) else f"#{index}"


def first_read(log: Path) -> FirstRead:
    with SessionLogReader(log) as reader:
        header = reader.header
        states: dict[str, BehaviorState] = header.initial_states_by_name()
        output_types: dict[str, str | None] = {}
        declared = declared_object(header.robot_state_schema, log)
        state_types: dict[str, str | None] = {}
        scan = declared is not None and holds_number_arrays(declared)
        non_finite: set[str] = set()
        samples: dict[str, Field | None] = {}
        for cycle in decoded_cycles(reader):
            for change in cycle.changes:
                states.setdefault(change.behavior, change.before)
            add_types(output_types, cycle.outputs)
            if declared is None:
                add_types(state_types, cycle.robot_state)
            elif scan:
                find_non_finite_arrays(declared, cycle.robot_state, "", non_finite)
            for sample in cycle.samples:
                samples[sample.sensor] = merged(
                    samples.get(sample.sensor), inferred(sample.value, log, cycle.number)
                )
        initial = {name: states.get(name) for name in header.behaviors}
        robot_state = typed_object(state_types) if declared is None else declared
        return FirstRead(
            initial, output_types, reader.status, robot_state, frozenset(non_finite), samples
        )


def states_after(states: dict[str, BehaviorState], changes: Sequence[StateChange]) -> None:
    """Apply a cycle's changes of catalogue behaviors to ``states``."""
    for change in changes:
        if change.behavior in states:
            states[change.behavior] = change.after


@contextmanager
def replacing_output(output: Path) -> Iterator[Path]:
    """A file to write next to ``output``, moved over it when the block completes."""
    part = output.with_name(f".{output.name}.part")
    try:
        yield part
        part.replace(output)
    except OSError as exc:
        raise ExportError(f"{output}: cannot write: {exc.strerror or exc}") from None
    finally:
        part.unlink(missing_ok=True)


# JSON


def log_metadata(session: Session) -> dict[str, str]:
    """What an export says of its log, as text: its header, and how and where it ends."""
    header, status = session.header, session.first.status
    return {
        "log": session.log.name,
        "format_version": str(header.format_version),
        "robot_id": header.robot_id,
        "software_version": header.software_version,
        "system": header.system,
        "robot_state_type": header.robot_state_type,
        "period_ns": str(header.period_ns),
        "start_time_ns": str(header.start_time_ns),
        "cycles": str(status.cycles),
        "complete": "true" if status.complete else "false",
        "status": status.describe(),
    }

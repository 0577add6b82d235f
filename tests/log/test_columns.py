"""Format 3: robot states stored by field read back byte for byte as format 2 holds them,
and a column that does not hold one value a cycle is a damaged log, read or not."""

from __future__ import annotations

import gc
import weakref
from pathlib import Path
from typing import Any

import msgspec
import pytest

from beatlog.errors import CorruptLogError
from beatlog.log.columns import Column, StateColumns, column_batches, encode_column
from beatlog.log.format import payload_encoder
from beatlog.log.reader import SessionLogReader
from tests.columned import (
    Damage,
    foreign_value,
    rewrite_by_field,
    short_column,
    table_off,
    write_states,
)
from tests.conftest import PERIOD_NS
from tests.crafting import read_all


class Pose(msgspec.Struct):
    x: float
    y: float


class Wide(msgspec.Struct):
    """A robot state of every kind of field a column holds."""

    speed: float
    ticks: int
    bumped: bool
    name: str
    pose: Pose
    ranges: list[float]


class Sparse(msgspec.Struct, omit_defaults=True):
    """A robot state whose cycles encode other fields when some are at their default."""

    a: float = 0.0
    b: float = 0.0


def wide(t: int) -> Wide:
    return Wide(
        speed=t / 7,
        ticks=t * 1_000_003 if t % 3 else -t,  # widths vary: stored unsplit
        bumped=t % 2 == 0,
        name=f"w{t}",
        pose=Pose(float(t), -0.0),
        ranges=[float("nan"), float(t)][: t % 3],
    )


def test_states_by_field_read_back_as_the_bytes_format_2_holds(tmp_path: Path) -> None:
    states = [wide(t) for t in range(30)]
    by_field, _ = read_all(write_states(tmp_path / "v3.beatlog", states, by_field=True))
    in_records, _ = read_all(write_states(tmp_path / "v3r.beatlog", states, by_field=False))
    format_2, _ = read_all(write_states(tmp_path / "v2.beatlog", states, by_field=False, version=2))
    encode = payload_encoder().encode
    assert [bytes(c.robot_state) for c in by_field] == [encode(s) for s in states]
    assert [msgspec.structs.astuple(c) for c in by_field] == [
        msgspec.structs.astuple(c) for c in format_2
    ]
    assert [msgspec.structs.astuple(c) for c in in_records] == [
        msgspec.structs.astuple(c) for c in format_2
    ]


def test_a_state_of_other_fields_starts_a_batch_that_names_them(tmp_path: Path) -> None:
    states = [Sparse(a=1.0), Sparse(a=2.0), Sparse(b=3.0), Sparse(), Sparse(a=4.0, b=5.0)]
    encode = payload_encoder().encode
    records = [encode([PERIOD_NS, None, [], [], {}, []]) for _ in states]
    made = column_batches(0, records, [encode(s) for s in states], ["a", "b"])
    assert [(start, b.first_cycle, b.state_fields) for start, b in made] == [
        (0, 0, ["a"]),
        (2, 2, ["b"]),
        (3, 3, None),  # no field at all: the state stays in its record
        (4, 4, []),  # the header's fields
    ]
    log = write_states(tmp_path / "sparse.beatlog", states, by_field=True)
    assert [bytes(c.robot_state) for c in read_all(log)[0]] == [encode(s) for s in states]


def test_a_column_of_one_width_is_stored_byte_split() -> None:
    values = [msgspec.msgpack.encode(v) for v in (1.5, -2.0)]
    assert encode_column(values) == Column(9, bytes([0xCB, 0xCB, 0x3F, 0xC0, 0xF8, 0, *[0] * 12]))
    assert encode_column([b"\x01", b"\xcd\x01\x00"]) == Column(0, b"\x01\xcd\x01\x00")


def test_a_column_table_checked_before_opens_a_batch_as_one_checked_afresh() -> None:
    """A reader remembers the column tables it checked (a speed trick, measured where
    it is defined): a batch of a table seen before opens as it would unremembered, and
    one whose data the table does not describe is refused all the same."""
    encode = payload_encoder().encode
    records = [encode((PERIOD_NS, None, [], [], {}, [])) for _ in range(16)]
    states = [encode(Pose(t / 3, -t / 7)) for t in range(16)]
    ((_, first),) = column_batches(0, records[:8], states[:8])
    ((_, second),) = column_batches(8, records[8:], states[8:])
    checked: dict[tuple[bytes, bytes, int], list[int]] = {}
    StateColumns(Path("v3.beatlog"), first, [], checked)
    assert len(checked) == 1
    remembered = StateColumns(Path("v3.beatlog"), second, [], checked)
    afresh = StateColumns(Path("v3.beatlog"), second, [], None)
    assert [remembered.encoded(i) for i in (0, 1)] == [afresh.encoded(i) for i in (0, 1)]
    cut = msgspec.structs.replace(second, data=second.data[:-1])
    for tables in (checked, None):
        with pytest.raises(CorruptLogError, match="its columns take 144 bytes, not the 143"):
            StateColumns(Path("v3.beatlog"), cut, [], tables)


class Labels(msgspec.Struct):
    """Two texts: columns of values of varied width."""

    a: str
    b: str


def test_a_column_table_of_the_same_widths_and_other_sizes_opens_as_its_own() -> None:
    """A remembered column table is one of the same widths, sizes and cycles: a batch of
    the same widths, its columns of other sizes, opens as it would unremembered."""
    encode = payload_encoder().encode
    records = [encode((PERIOD_NS, None, [], [], {}, [])) for _ in range(16)]
    first_labels = [Labels("x" * (t % 2), "y" * (t % 3)) for t in range(8)]
    states = [encode(s) for s in [*first_labels, *(Labels(s.b, s.a) for s in first_labels)]]
    ((_, first),) = column_batches(0, records[:8], states[:8])
    ((_, second),) = column_batches(8, records[8:], states[8:])
    assert (first.widths, len(first.data)) == (second.widths, len(second.data))
    assert first.sizes != second.sizes
    checked: dict[tuple[bytes, bytes, int], list[int]] = {}
    StateColumns(Path("v3.beatlog"), first, [], checked)
    remembered = StateColumns(Path("v3.beatlog"), second, [], checked)
    afresh = StateColumns(Path("v3.beatlog"), second, [], None)
    assert [remembered.encoded(i) for i in (0, 1)] == [afresh.encoded(i) for i in (0, 1)]


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        (short_column(0), "field 'speed' holds 71 bytes, not 8 values of 9 bytes"),
        (table_off, "its columns take"),
        (foreign_value(0), "field 'speed'"),
    ],
    ids=["short", "table", "foreign"],
)
def test_a_column_that_does_not_hold_one_value_a_cycle_is_a_damaged_log(
    tmp_path: Path, damage: Damage, words: str
) -> None:
    log = write_states(tmp_path / "v3.beatlog", [wide(t) for t in range(30)], by_field=True)
    damaged = rewrite_by_field(log, tmp_path / "damaged.beatlog", damage, 1)
    with pytest.raises(CorruptLogError, match="damaged batch from cycle 8") as raised:
        read_all(damaged)
    assert words in str(raised.value)


def test_a_short_column_is_found_though_replay_would_not_read_it(tmp_path: Path) -> None:
    log = write_states(tmp_path / "v3.beatlog", [wide(t) for t in range(30)], by_field=True)
    damaged = rewrite_by_field(log, tmp_path / "damaged.beatlog", short_column(0), 1)
    with SessionLogReader(damaged) as reader:
        reader.decode_states(Wide)  # states stay in their columns: none is decoded
        with pytest.raises(CorruptLogError) as raised:
            list(reader.batches())
    assert str(raised.value) == (
        f"{damaged}: damaged batch from cycle 8: field 'speed' holds 71 bytes, not 8 values of "
        "9 bytes (a value missing, repeated or foreign)"
    )


def test_columns_decoded_together_are_each_column_decoded_alone(tmp_path: Path) -> None:
    states = [wide(t) for t in range(30)]
    log = write_states(tmp_path / "v3.beatlog", states, by_field=True)
    fields = msgspec.structs.fields(Wide)
    decoders = [msgspec.msgpack.Decoder(list[f.type]).decode for f in fields]  # type: ignore[name-defined]
    indices = list(range(len(fields)))
    with SessionLogReader(log) as reader:
        reader.decode_states(Wide)
        batch = next(reader.batches())
        together: Any = batch[0].robot_state
        assert isinstance(together, StateColumns)
        together.decoded([0, 4], [decoders[0], decoders[4]], "Wide")  # two un-split first
        found = together.decoded(indices, decoders, "Wide")
        reader_again = SessionLogReader(log)
    with reader_again:
        reader_again.decode_states(Wide)
        alone: Any = next(reader_again.batches())[0].robot_state
        one_by_one = [alone.values(i, decode, "Wide") for i, decode in enumerate(decoders)]
    expected = [[getattr(state, f.name) for state in states[:8]] for f in fields]
    encode = payload_encoder().encode  # NaN among the values: compared as bytes
    assert (encode(found), encode(one_by_one)) == (encode(expected), encode(expected))


@pytest.mark.parametrize(
    ("fixed", "varied"),
    [
        (["speed", "bumped", "pose"], []),
        (["pose", "speed"], []),
        (["bumped"], ["ranges", "ticks"]),
        ([], ["ticks"]),
        ([], []),
    ],
    ids=["in-order", "reordered", "and-varied", "varied", "none"],
)
def test_a_cycle_of_columns_is_one_array_of_its_values(
    tmp_path: Path, fixed: list[str], varied: list[str]
) -> None:
    states = [wide(t) for t in range(30)]
    log = write_states(tmp_path / "v3.beatlog", states, by_field=True)
    names = [f.name for f in msgspec.structs.fields(Wide)]
    with SessionLogReader(log) as reader:
        reader.decode_states(Wide)
        batches: list[Any] = [batch[0].robot_state for batch in reader.batches()]
    widths = {"speed": 9, "bumped": 1, "pose": 23, "ranges": 0, "ticks": 0}
    assert [
        [columns.widths[names.index(name)] for name in fixed + varied] for columns in batches
    ] == [[widths[name] for name in fixed + varied]] * len(batches)
    at = [list(map(names.index, fixed)), list(map(names.index, varied))]
    rows = [row for columns in batches for row in columns.rows(*at)]
    encode = msgspec.msgpack.encode
    assert rows == [encode([getattr(state, name) for name in fixed + varied]) for state in states]


def test_a_batch_read_by_field_is_freed_without_the_garbage_collector(tmp_path: Path) -> None:
    log = write_states(tmp_path / "v3.beatlog", [wide(t) for t in range(30)], by_field=True)
    with SessionLogReader(log) as reader:
        reader.decode_states(Wide)
        batches = reader.batches()
        gc.disable()
        try:
            columns = weakref.ref(next(batches)[0].robot_state)
            next(batches)
            freed = columns() is None
        finally:
            gc.enable()
    assert freed

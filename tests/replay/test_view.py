"""Replaying a log whose robot states are stored by field: behaviors get a view of RS_t
that decodes a field's column the first time it is read, and behaves as the state."""

from __future__ import annotations

import copy
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import msgspec
import pytest

import beatlog
from beatlog.errors import CorruptLogError, SchemaMismatchError
from beatlog.log.format import ColumnBatch
from beatlog.log.reader import SessionLogReader
from beatlog.model import BehaviorState, Context, Outputs, PriorityArbiter, RobotState
from beatlog.record import Recorder
from beatlog.replay import StateMigration
from beatlog.replay.view import StateViews, full_state
from tests.columned import (
    Damage,
    retyped_value,
    rewrite_by_field,
    same_width_values,
    short_column,
    write_states,
)
from tests.conftest import PERIOD_NS

LATE = 200
"""The cycle in which the behavior first reads ``late``."""


class Pose(msgspec.Struct):
    x: float = 0.0
    y: float = 0.0


class Arm(RobotState, kw_only=True):
    """A robot state with a method, a property, a nested struct and a list."""

    reach: float = 0.0
    late: float = 0.0
    label: str = ""
    pose: Pose = msgspec.field(default_factory=Pose)
    joints: list[int] = msgspec.field(default_factory=list)

    def doubled(self) -> float:
        return 2 * self.reach

    @property
    def far(self) -> bool:
        return self.reach > 0.5


class Watcher:
    """Outputs what it reads of the state, and ``late`` only from cycle :data:`LATE` on."""

    name = "watcher"

    def __init__(self) -> None:
        self.state: BehaviorState = "idle"
        self.seen: list[tuple[int, float]] = []

    def step(self, rs: Arm, ctx: Context) -> Outputs | None:
        assert isinstance(rs, Arm)
        assert rs.__class__ is Arm
        self.state = "far" if rs.far else "near"
        outputs: Outputs = {"doubled": rs.doubled(), "x": rs.pose.x, "joints": rs.joints}
        if ctx.cycle >= LATE:
            self.seen.append((ctx.cycle, rs.late))
            outputs["late"] = rs.late
        return outputs


def watcher_system() -> PriorityArbiter[Arm]:
    return PriorityArbiter([Watcher()], robot_state=Arm)


def arm(t: int) -> Arm:
    return Arm(
        reach=(t % 17) / 16,
        late=t * 0.25,
        label="x" * (t % 3),  # values of varied width
        pose=Pose(float(t), -float(t)),
        joints=list(range(t % 4)),
    )


def record(path: Path, cycles: int = 300, *, by_field: bool = True) -> Path:
    with Recorder(path, watcher_system(), seed=1, software="test", by_field=by_field) as r:
        for t in range(cycles):
            r.step(PERIOD_NS, arm(t))
    return path


@pytest.fixture(scope="module")
def by_field(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record(tmp_path_factory.mktemp("view") / "arm.beatlog")


def test_a_field_first_read_in_cycle_200_gets_its_recorded_value(by_field: Path) -> None:
    system = watcher_system()
    result = beatlog.replay(by_field, system)
    assert (result.ok, result.cycles) == (True, 300)
    watcher = system.behaviors["watcher"]
    assert isinstance(watcher, Watcher)
    assert watcher.seen == [(t, t * 0.25) for t in range(LATE, 300)]


def test_the_same_session_in_the_records_replays_alike(by_field: Path, tmp_path: Path) -> None:
    in_records = record(tmp_path / "rows.beatlog", by_field=False)
    systems = [watcher_system(), watcher_system()]
    results = [
        beatlog.replay(log, s) for log, s in zip((by_field, in_records), systems, strict=True)
    ]
    assert [(r.ok, r.cycles, r.checked) for r in results] == [(True, 300, results[0].checked)] * 2
    assert [s.behaviors["watcher"].state for s in systems] == ["far", "far"]


def test_a_view_is_the_state_where_the_whole_state_is_needed(by_field: Path) -> None:
    system = watcher_system()
    viewed: list[object] = []
    beatlog.replay(by_field, system, observe=viewed.append)
    assert len(viewed) == 300
    with SessionLogReader(by_field) as reader:
        reader.decode_states(Arm)
        views = StateViews(Arm, Arm, by_field)
        batch = next(reader.batches())
        columns: Any = batch[3].robot_state
        view = views.view(columns, 3)
    assert isinstance(view, Arm)
    assert full_state(view) == arm(3)
    assert type(full_state(view)) is Arm
    assert view == arm(3)
    assert repr(view) == repr(arm(3))
    assert copy.deepcopy(view) == arm(3)
    assert (view.label, view.joints, view.pose) == ("", [0, 1, 2], Pose(3.0, -3.0))


def test_an_attribute_the_state_lacks_is_missing_from_its_view_as_from_the_state(
    by_field: Path,
) -> None:
    with SessionLogReader(by_field) as reader:
        reader.decode_states(Arm)
        columns: Any = next(reader.batches())[3].robot_state
        view = StateViews(Arm, Arm, by_field).view(columns, 3)
    missing = []
    for state in (arm(3), view):
        with pytest.raises(AttributeError) as raised:
            getattr(state, "nope")  # noqa: B009 - an attribute neither has
        missing.append(str(raised.value))
    assert missing == ["'Arm' object has no attribute 'nope'"] * 2
    assert (view.reach, hasattr(view, "nope")) == (arm(3).reach, False)


def test_a_field_read_before_its_view_holds_it_reads_as_once_held(by_field: Path) -> None:
    """A field a view does not hold is read through its class (for speed), one it holds
    from the view itself: pinned to each other and to the state decoded whole, in every
    cycle, each field read first there."""
    fields = Arm.__struct_fields__
    unheld, held = [], []
    with SessionLogReader(by_field) as reader:
        reader.decode_states(Arm)
        for batch in reader.batches():
            columns: Any = batch[0].robot_state
            for cycle in range(columns.first_cycle, columns.first_cycle + len(batch)):
                views = StateViews(Arm, Arm, by_field)
                first = views.view(columns, cycle)
                assert not {*fields} & {*type(first).__struct_fields__}
                unheld.append([getattr(first, name) for name in fields])
                again = views.view(columns, cycle)
                assert {*fields} <= {*type(again).__struct_fields__}
                held.append([getattr(again, name) for name in fields])
                assert full_state(first) == full_state(again) == arm(cycle)
    assert unheld == held == [[getattr(arm(t), name) for name in fields] for t in range(300)]


def viewed_batches(
    log: Path, state_type: type[Any], fields: Sequence[str]
) -> Iterator[tuple[StateViews, Any, list[list[Any]]]]:
    """Each batch of ``log`` as views of ``state_type`` read it: the views, the batch's
    columns, and ``fields`` of each of its cycles."""
    with SessionLogReader(log) as reader:
        reader.decode_states(state_type)
        views = StateViews(state_type, state_type, log)
        for batch in reader.batches():
            columns: Any = batch[0].robot_state
            cycles = range(columns.first_cycle, columns.first_cycle + len(batch))
            rows = [[getattr(views.view(columns, t), name) for name in fields] for t in cycles]
            yield views, columns, rows


def read_views(log: Path, state_type: type[Any], fields: list[str]) -> list[list[Any]]:
    """``fields`` of every cycle of ``log``, read from views of ``state_type``."""
    return [row for _, _, rows in viewed_batches(log, state_type, fields) for row in rows]


def test_views_of_a_type_read_alike_the_first_time_in_a_process_and_after(
    by_field: Path,
) -> None:
    """What the views of a robot state type are made of (their fields and classes) is
    made once a process (for speed): pinned, views made from it read as the first ones
    made, and views of another type of the same name read its own fields."""
    fields = ["reach", "label", "joints"]
    first = msgspec.defstruct("Arm", [], bases=(Arm,), kw_only=True, module=__name__)
    other = msgspec.defstruct(
        "Arm", [("added", int, 7)], bases=(Arm,), kw_only=True, module=__name__
    )
    made, again = read_views(by_field, first, fields), read_views(by_field, first, fields)
    assert made == again == [[getattr(arm(t), name) for name in fields] for t in range(300)]
    assert read_views(by_field, other, [*fields, "added"]) == [[*row, 7] for row in made]


def test_an_unread_column_short_of_a_value_is_still_a_damaged_log(
    by_field: Path, tmp_path: Path
) -> None:
    damaged = rewrite_by_field(by_field, tmp_path / "short.beatlog", short_column(1), 2)
    with pytest.raises(CorruptLogError, match="field 'late' holds") as raised:
        beatlog.replay(damaged, watcher_system())  # 'late' is first read in cycle 200
    assert str(raised.value).startswith(f"{damaged}: damaged batch from cycle ")


@pytest.mark.parametrize(
    ("damage", "problem"),
    [
        (retyped_value(4, "oops"), "field 'joints': Expected `array`, got `str` - at `$[0]`"),
        (
            same_width_values(0, "8 chars!"),
            "field 'reach': Expected `float`, got `str` - at `$[0]`",
        ),
    ],
    ids=["varied-width", "one-width"],  # decoded a column at a time, a cycle at a time
)
def test_a_value_of_another_type_is_found_where_it_is_read(
    by_field: Path, tmp_path: Path, damage: Damage, problem: str
) -> None:
    damaged = rewrite_by_field(by_field, tmp_path / "typed.beatlog", damage, 1)
    with pytest.raises(SchemaMismatchError) as raised:
        beatlog.replay(damaged, watcher_system())
    assert str(raised.value) == f"{damaged}: robot state of cycle 35 does not fit Arm: {problem}"


def test_a_batch_naming_a_field_the_state_lacks_does_not_fit(
    by_field: Path, tmp_path: Path
) -> None:
    with SessionLogReader(by_field) as reader:
        names = ["nope" if name == "late" else name for name in reader.header.state_fields]

    def renamed(batch: ColumnBatch) -> ColumnBatch:
        return msgspec.structs.replace(batch, state_fields=names)

    damaged = rewrite_by_field(by_field, tmp_path / "renamed.beatlog", renamed, 1)
    with pytest.raises(SchemaMismatchError) as raised:
        beatlog.replay(damaged, watcher_system())
    assert str(raised.value) == (
        f"{damaged}: robot state of cycle 35 does not fit Arm: object contains unknown field `nope`"
    )


def test_a_value_spilling_into_the_next_ones_place_is_a_damaged_log(
    by_field: Path, tmp_path: Path
) -> None:
    spilling = {"x": 1.0, "y": 2.0, "z": "s" * 19}  # 45 bytes after a 1-byte Pose
    damage = same_width_values(3, {}, spilling)  # 'pose', two values of 23 bytes
    damaged = rewrite_by_field(by_field, tmp_path / "spilling.beatlog", damage, 1)
    with pytest.raises(CorruptLogError) as raised:
        beatlog.replay(damaged, watcher_system())
    assert str(raised.value) == (
        f"{damaged}: damaged batch from cycle 35: a column of values of one width does not "
        "hold one value of that width a cycle"
    )


@pytest.mark.parametrize(
    ("fields", "layout"),
    [
        (["reach", "late", "pose"], ([0, 1, 3], [], ())),  # of one width: a cycle at a time
        (list(Arm.__struct_fields__), ([0, 1, 3], [2, 4], ())),  # of varied width joined on
        (["label", "joints", "reach"], ([], [], ("label", "joints", "reach"))),  # by column
    ],
    ids=["one-width", "most-of-one-width", "most-of-varied-width"],
)
def test_views_hold_the_recorded_states_however_they_are_decoded(
    by_field: Path, fields: list[str], layout: tuple[list[int], list[int], tuple[str, ...]]
) -> None:
    read, layouts = [], set()
    for views, columns, rows in viewed_batches(by_field, Arm, fields):
        read += rows
        made = views.layout(columns, tuple(fields))
        layouts.add((tuple(made.columns), tuple(made.varied), made.rest))
    assert read == [[getattr(arm(t), name) for name in fields] for t in range(300)]
    assert layouts == {(tuple(layout[0]), tuple(layout[1]), layout[2])}


def test_a_state_decoded_for_checking_is_the_one_a_plain_decode_gives(tmp_path: Path) -> None:
    """RS_t decoded as the checking subclass becomes the system's by its ``__class__``
    set (for speed): the behaviors get exactly what decoding as the system's type gives."""
    log = record(tmp_path / "rows.beatlog", by_field=False)
    outcomes: list[Any] = []
    assert beatlog.replay(log, watcher_system(), observe=outcomes.append).ok
    with SessionLogReader(log) as reader:
        plain = [msgspec.msgpack.decode(r.robot_state, type=Arm) for r in reader.cycles()]
    seen = [outcome.state for outcome in outcomes]
    assert [type(state) for state in seen] == [Arm] * 300
    assert seen == plain
    assert [msgspec.msgpack.encode(state) for state in seen] == list(
        map(msgspec.msgpack.encode, plain)
    )


Renamed = msgspec.defstruct(
    "Arm",
    [
        ("extent", float, 0.0),
        ("late", str, ""),
        ("label", str, ""),
        ("pose", Pose, msgspec.field(default_factory=Pose)),
        ("joints", list[int], msgspec.field(default_factory=list)),
        ("added", int, 7),
    ],
    bases=(RobotState,),
    kw_only=True,
    module=__name__,
)
""":class:`Arm` as it is now: ``reach`` renamed, ``late`` retyped to a string, a field
added with a default."""


class RenamedWatcher:
    name = "watcher"

    def __init__(self) -> None:
        self.state: BehaviorState = "idle"
        self.read: list[tuple[float, str, int]] = []

    def step(self, rs: Any, ctx: Context) -> Outputs | None:
        """What :class:`Watcher` does, through the fields' new names and types."""
        self.read.append((rs.extent, rs.late, rs.added))
        self.state = "far" if rs.extent > 0.5 else "near"
        outputs: Outputs = {"doubled": 2 * rs.extent, "x": rs.pose.x, "joints": rs.joints}
        if ctx.cycle >= LATE:
            outputs["late"] = float(rs.late)
        return outputs


def as_text(value: float) -> str:
    return f"{value:.2f}"


def test_renamed_converted_and_added_fields_read_as_the_system_has_them(
    by_field: Path,
) -> None:
    watcher = RenamedWatcher()
    system = PriorityArbiter([watcher], robot_state=Renamed)
    migration = StateMigration(
        renames={"reach": "extent"}, conversions={"late": "tests.replay.test_view:as_text"}
    )
    result = beatlog.replay(by_field, system, migration=migration)
    assert (result.ok, result.cycles) == (True, 300)
    assert watcher.read == [(arm(t).reach, as_text(t * 0.25), 7) for t in range(300)]


class Sparse(RobotState, omit_defaults=True):
    """A robot state whose cycles encode one field or the other."""

    a: float = 0.0
    b: float = 0.0


def sparse(t: int) -> Sparse:
    """Only ``a`` in the first 8 cycles (a batch), only ``b`` in the next 8, and so on."""
    return Sparse(a=t + 0.5) if t // 8 % 2 == 0 else Sparse(b=t + 0.5)


def test_batches_of_other_fields_in_columns_of_the_same_widths_read_each_their_own(
    tmp_path: Path,
) -> None:
    log = write_states(tmp_path / "sparse.beatlog", [sparse(t) for t in range(32)], by_field=True)
    names, read = [], []
    with SessionLogReader(log) as reader:
        reader.decode_states(Sparse)
        views = StateViews(Sparse, Sparse, log)
        for batch in reader.batches():
            columns: Any = batch[0].robot_state
            names.append((columns.names, columns.widths))
            for cycle in range(columns.first_cycle, columns.first_cycle + len(batch)):
                view = views.view(columns, cycle)
                read.append((view.a, view.b))
    assert names == [(["a"], b"\x09"), (["b"], b"\x09")] * 2
    assert read == [(sparse(t).a, sparse(t).b) for t in range(32)]


class Tagged(RobotState):
    """A robot state whose text fields are of one width in some batches, not in others."""

    a: float = 0.0
    label: str = ""
    note: str = ""


def tagged(t: int) -> Tagged:
    """Empty texts in the first 8 cycles (a batch), texts of varied width in the next 8,
    and so on."""
    if t // 8 % 2 == 0:
        return Tagged(a=t + 0.5)
    return Tagged(a=t + 0.5, label="x" * (t % 3), note="y" * (t % 2))


def test_a_batch_laid_out_as_an_earlier_one_is_laid_out_as_afresh(tmp_path: Path) -> None:
    """Views of a batch are laid out once per layout of the batches (for speed): pinned to
    the layout made afresh for each batch, through batches of two layouts in turn."""
    log = write_states(tmp_path / "tagged.beatlog", [tagged(t) for t in range(32)], by_field=True)
    fields = Tagged.__struct_fields__
    kept, afresh = [], []
    read: list[tuple[Any, ...]] = []
    for views, columns, rows in viewed_batches(log, Tagged, fields):
        read += map(tuple, rows)
        kept.append(views.layout(columns, fields))
        fresh = StateViews(Tagged, Tagged, log)
        fresh.view(columns, columns.first_cycle)
        afresh.append(fresh.layout(columns, fields))
    assert kept == afresh
    assert len({(tuple(made.columns), made.rest) for made in kept}) == 2
    assert read == [tuple(getattr(tagged(t), name) for name in fields) for t in range(32)]

"""RS_t as the behaviors get it from a format-3 log: a view that decodes a field's column
the first time a behavior reads the field.

A format-3 batch stores each robot-state field's values in a column of their own
(:mod:`beatlog.log.columns`). A view holds the fields read so far in the replay; a field
first read later is decoded then (its column, once per batch) and held from the next
batch on, so decoding follows the fields read, not the width of the state.

What a behavior can rely on (the how-to "Wide robot states"): a field reads as recorded,
its type checked; ``isinstance(state, YourState)`` holds and its methods work; equality,
``repr``, copying and pickling act on the whole state. Anything else that needs the whole
struct (encoding, ``asdict``, ``replace``, ``type(state) is``) takes :func:`full_state`.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable
from itertools import repeat
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.errors import ConversionError, CorruptLogError, SchemaMismatchError
from beatlog.log.columns import StateColumns
from beatlog.log.format import DECODE_ERRORS
from beatlog.replay.fit.migration import StateConverter

__all__ = ["StateViews", "full_state"]

BATCH = "_beatlog_batch"
"""The attribute of a view that holds its batch."""
INDEX = "_beatlog_index"
"""The attribute of a view that holds where its cycle is in the batch."""
_KEPT = 64
"""How many batch layouts, view classes and shapes are kept, each."""


def full_state(state: Any) -> Any:
    """The robot state itself, every field decoded, for a view (:class:`StateViews`);
    any other state as it is."""
    batch = getattr(state, BATCH, None)
    if isinstance(batch, ViewedBatch):
        cycle = batch.columns.first_cycle + getattr(state, INDEX)
        return batch.views_of.decode_whole(batch.columns.raw_state(cycle), cycle)
    return state


class _View(msgspec.Struct, array_like=True, gc=False, weakref=False):
    """What every view's class derives from: what needs the whole state acts on it."""

    def __eq__(self, other: object) -> bool:
        return bool(full_state(self) == full_state(other))

    def __repr__(self) -> str:
        return repr(full_state(self))

    def __copy__(self) -> Any:
        return copy.copy(full_state(self))

    def __deepcopy__(self, memo: dict[int, Any]) -> Any:
        return copy.deepcopy(full_state(self), memo)

    def __reduce__(self) -> Any:
        return full_state(self).__reduce__()

    __hash__ = None  # type: ignore[assignment]


# A class attribute, not a ``__getattr__`` that makes every read dearer: 5.5 % of a whole
# replay of the dog's wall-follow stored by field (163.0 -> 154.0 M instructions,
# cachegrind; 1.4 % at 1,000 fields).
class _Unheld:
    """A field a view does not hold, as an attribute of its class: read, it is decoded
    from its column (and held from the next batch on)."""

    __slots__ = ("name",)

    def __init__(self, name: str) -> None:
        self.name = name

    def __get__(self, view: Any, owner: type[Any] | None = None) -> Any:
        if view is None:
            return self
        batch: ViewedBatch = getattr(view, BATCH)
        views = batch.views_of
        if self.name not in views.read:
            views.read[self.name] = None
            views.stale = True
        return batch.held((self.name,))[0][getattr(view, INDEX)]


class BatchLayout(NamedTuple):
    """How a batch gives its views (:meth:`StateViews.layout`)."""

    columns: list[int]
    """The columns of values of one width decoded a cycle at a time, in field order."""
    varied: list[int]
    """The columns of values of varied width decoded a cycle at a time, after them."""
    rest: tuple[str, ...]
    """The fields held decoded a column at a time and set after."""
    view: type[Any]
    """The class of the views."""
    decode: Callable[[bytes], Any]
    """A view decoded from a cycle's array of the values of the columns above."""


class StateViews:
    """Views of the system's robot state over format-3 batches, for the replay core.

    A batch may hold no field ``checking``, the type each RS_t must fit
    (:func:`~beatlog.replay.fit.schema.recorded_state_type`), lacks, and must hold
    every one it requires, each decoded as its type there; the fields ``convert``
    converts become the system's as they are decoded.
    """

    def __init__(
        self,
        system_type: type,
        checking: type,
        path: Path,
        convert: StateConverter | None = None,
    ) -> None:
        self.system_type = system_type
        self.path = path
        self.convert = convert
        self.shape = _shape(system_type, checking)
        """What views of these types share in a process: their fields and classes."""
        self.fields = self.shape.fields
        self.read: dict[str, None] = {}
        """The fields read so far, in the order first read: each view holds them."""
        self.stale = False
        """Whether a field was first read in the batch the views are of."""
        self.index: dict[str, int] = {}
        """Each field's column, by its encoded name, in the batch viewed last."""
        self._names: list[str] | None = None
        self._layouts: dict[tuple[bytes, tuple[str, ...]], BatchLayout] = {}
        self._columns: StateColumns | None = None
        self._batch: ViewedBatch | None = None
        self._views: list[Any] = []

    def view(self, columns: StateColumns, cycle: int) -> Any:
        """RS_t of ``cycle``, one of the batch ``columns`` holds."""
        if columns is not self._columns or self.stale:
            self._open(columns)
        return self._views[cycle - columns.first_cycle]

    def _open(self, columns: StateColumns) -> None:
        """Make a batch's views (again, holding one more field, when a behavior read a
        field first in it), its fields checked against the type where they are not
        those of the batch before."""
        batch = self._batch
        if batch is None or columns is not self._columns:
            names = columns.names
            shape = self.shape
            if names is not self._names and names is not None:
                problems = [
                    *(f"contains unknown field `{n}`" for n in names if n not in shape.recorded),
                    *(f"missing required field `{n}`" for n in sorted(shape.required - {*names})),
                ]
                if problems:
                    raise SchemaMismatchError(
                        self.path,
                        f"robot state of cycle {columns.first_cycle} does not fit "
                        f"{self.system_type.__name__}: object {problems[0]}",
                    )
            if names is not self._names:
                self.index = {name: at for at, name in enumerate(names or ())}
                self._names, self._layouts = names, {}
            batch = self._batch = ViewedBatch(self, columns)
            self._columns = columns
        self.stale = False
        self._views = batch.views(tuple(self.read))

    def layout(self, columns: StateColumns, held: tuple[str, ...]) -> BatchLayout:
        """How the batch of ``columns``, viewed last, gives views holding the fields
        ``held`` (made once per batch layout): the fields it stores, unless converted,
        decoded a cycle at a time (those of one width first, in column order), the others
        a column at a time; where most are of varied width, all a column at a time, which
        costs less."""
        # Once a layout, not a batch: 3.2 % of a whole replay of 1,000 fields stored by
        # field, 30 read, 3,000 cycles (569.6 -> 551.6 M instructions, cachegrind); 2.9 %
        # of the dog's wall-follow stored by field (158.6 -> 154.0 M).
        index = self.index
        found = self._layouts.get((columns.widths, held))
        if found is None:
            converted = self.convert.fields if self.convert is not None else ()
            stored = sorted(
                (not columns.widths[column], column, name)
                for name in held
                if (column := index.get(self.fields[name].encode_name)) is not None
                and name not in converted
            )
            if 2 * sum(of_varied for of_varied, _, _ in stored) > len(stored):
                stored = []
            in_rows = tuple(name for _, _, name in stored)
            rest = tuple(name for name in held if name not in in_rows)
            if len(self._layouts) >= _KEPT:
                self._layouts.clear()
            found = self._layouts[columns.widths, held] = BatchLayout(
                [column for of_varied, column, _ in stored if not of_varied],
                [column for of_varied, column, _ in stored if of_varied],
                rest,
                *self.shape.view_class(in_rows, rest),
            )
        return found

    def adopt(self, state: Any, cycle: int) -> Any:
        """A state decoded as the checking type made the system's, its fields converted.

        :raises beatlog.errors.SchemaMismatchError: a conversion failed.
        """
        if state.__class__ is not self.system_type:
            # Its class set, not the system's type made anew from its fields: whole
            # state-level replays of the rover's 35,000 cycles and the dog's wall-follow
            # take 12.7 % and 11.9 % fewer instructions (1,334.7 M against 1,528.6 M;
            # 200.3 M against 227.3 M, cachegrind).
            state.__class__ = self.system_type
        if self.convert is not None:
            self.converting(cycle, self.convert, state)
        return state

    def converting(self, cycle: int, convert: Callable[..., Any], *values: Any) -> Any:
        """``convert(*values)`` for a robot state of ``cycle``, or a field of it.

        :raises beatlog.errors.SchemaMismatchError: the conversion failed.
        """
        try:
            return convert(*values)
        except ConversionError as exc:
            error = SchemaMismatchError(self.path, f"robot state of cycle {cycle}: {exc}")
            error.user_traceback = exc.user_traceback
            raise error from None

    def decode_whole(self, encoded: bytes, cycle: int) -> Any:
        """RS_t of ``cycle`` decoded whole from its encoding, the system's."""
        try:
            decoded = self.shape.whole(encoded)
        except DECODE_ERRORS as exc:
            raise SchemaMismatchError(
                self.path,
                f"robot state of cycle {cycle} does not fit {self.system_type.__name__}: {exc}",
            ) from None
        return self.adopt(decoded, cycle)


class ViewedBatch:
    """One batch's columns as its views read them: each decoded once, on first read."""

    __slots__ = ("columns", "decoded", "index", "views_of")

    def __init__(self, views: StateViews, columns: StateColumns) -> None:
        self.views_of = views
        self.columns = columns
        self.index = views.index
        self.decoded: dict[str, list[Any]] = {}

    def views(self, held: tuple[str, ...]) -> list[Any]:
        """The batch's views, holding the fields ``held`` (:meth:`StateViews.layout`).

        :raises beatlog.errors.SchemaMismatchError: a value does not fit its field's type
            (found as decoding the columns in the order read would find it).
        :raises beatlog.errors.CorruptLogError: a column is damaged.
        """
        layout = self.views_of.layout(self.columns, held)
        if not layout.columns and not layout.varied:
            values = self.held(layout.rest)
            return list(map(layout.view, *values, repeat(self), range(self.columns.count)))
        try:
            views = list(map(layout.decode, self.columns.rows(layout.columns, layout.varied)))
        except (msgspec.ValidationError, *DECODE_ERRORS):
            self.held(held)  # found again, to say where
            raise CorruptLogError(
                self.views_of.path,
                f"damaged batch from cycle {self.columns.first_cycle}: a column of values "
                "of one width does not hold one value of that width a cycle",
            ) from None
        for index, view in enumerate(views):
            setattr(view, BATCH, self)
            setattr(view, INDEX, index)
        for name, values in zip(layout.rest, self.held(layout.rest), strict=True):
            for view, value in zip(views, values, strict=True):
                setattr(view, name, value)
        return views

    def held(self, names: tuple[str, ...]) -> list[list[Any]]:
        """Fields ``names`` of every cycle of the batch, the system's: the columns not
        decoded yet are decoded together (:meth:`StateColumns.decoded`), a field the
        system gained since the recording takes its default."""
        decoded = self.decoded
        fresh = [name for name in names if name not in decoded]
        if fresh:
            views = self.views_of
            fields = views.fields
            stored = [name for name in fresh if fields[name].encode_name in self.index]
            found = self.columns.decoded(
                [self.index[fields[name].encode_name] for name in stored],
                list(map(views.shape.decoder, stored)),
                views.system_type.__name__,
            )
            convert = views.convert
            first = self.columns.first_cycle
            for name, values in zip(stored, found, strict=True):
                decoded[name] = (
                    [
                        views.converting(cycle, convert.value, name, value)
                        for cycle, value in enumerate(values, first)
                    ]
                    if convert is not None and name in convert.fields
                    else values
                )
            for name in fresh:
                if name not in decoded:
                    info = fields[name]
                    make = info.default_factory
                    count = self.columns.count
                    decoded[name] = (
                        [make() for _ in range(count)]
                        if make is not msgspec.NODEFAULT
                        else [info.default] * count
                    )
        return [decoded[name] for name in names]


class _Shape:
    """What the views of one robot state type (``system_type``, checked as ``checking``)
    share, made once per pair in a process (:func:`_shape`): a suite replays many logs
    of one robot, and at 1,000 fields reading the fields alone takes milliseconds."""

    def __init__(self, system_type: type[Any], checking: type[Any]) -> None:
        self.system_type = system_type
        struct = isinstance(checking, type) and issubclass(checking, msgspec.Struct)
        self.fields: dict[str, Any] = (
            {info.name: info for info in msgspec.structs.fields(checking)} if struct else {}
        )
        self.recorded = {info.encode_name for info in self.fields.values()}
        """The fields' encoded names."""
        self.required = {info.encode_name for info in self.fields.values() if info.required}
        """The encoded names of the fields without a default."""
        self.whole: Callable[[bytes], Any] = msgspec.msgpack.Decoder(checking).decode
        """RS_t decoded whole, as ``checking``."""
        self._namespace = {"__class__": system_type, "__qualname__": system_type.__qualname__}
        """The views' class attributes: with these, the user's own methods, properties and
        class attributes."""
        for klass in reversed(system_type.__mro__):
            if not klass.__module__.startswith("msgspec") and klass is not object:
                self._namespace.update(
                    (name, value)
                    for name, value in vars(klass).items()
                    if not name.startswith(("__", "_beatlog")) and name not in self.fields
                )
        self._views: dict[tuple[tuple[str, ...], ...], tuple[type[Any], Callable[..., Any]]] = {}

    def view_class(
        self, in_rows: tuple[str, ...], rest: tuple[str, ...]
    ) -> tuple[type[Any], Callable[[bytes], Any]]:
        """The class of views holding the fields ``in_rows`` and ``rest``, and what
        decodes one from an array of the values of ``in_rows`` (each as its field's
        type), ``rest`` set after; without ``in_rows``, views are made positionally."""
        # Kept with the shape, made once a process: a replay of 10 behaviors reading a
        # 1,000-field state, after another, takes 6.7 % fewer instructions (279.4 k a cycle
        # against 298.1 k, cachegrind).
        found = self._views.get((in_rows, rest))
        if found is None:
            held = {*in_rows, *rest}
            view = msgspec.defstruct(
                self.system_type.__name__,
                [
                    *((name, self.fields[name].type) for name in in_rows),
                    *((name, Any, None) for name in rest),
                    (BATCH, Any, None),
                    (INDEX, int, 0),
                ],
                bases=(_View,),
                module=self.system_type.__module__,
                namespace={
                    **self._namespace,
                    **{name: _Unheld(name) for name in self.fields if name not in held},
                },
            )
            if len(self._views) >= _KEPT:
                self._views.clear()
            found = self._views[in_rows, rest] = (view, msgspec.msgpack.Decoder(view).decode)
        return found

    def decoder(self, name: str) -> Callable[[bytes], list[Any]]:
        """What decodes a column of field ``name`` (a msgpack array) as the field's type."""
        kind = self.fields[name].type
        return msgspec.msgpack.Decoder(list[kind]).decode  # type: ignore[valid-type]


# Made once a process, not once a replay, with the classes they keep: 4.1 % of a whole
# replay of 1,000 fields stored by field, after another (575.2 -> 551.6 M instructions).
@functools.lru_cache(maxsize=_KEPT)
def _shape(system_type: type, checking: type) -> _Shape:
    """The :class:`_Shape` of the pair, made on first need."""
    return _Shape(system_type, checking)

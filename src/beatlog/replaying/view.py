"""RS_t as the behaviors get it from a format-3 log: a view that decodes a field's column
the first time a behavior reads the field (a batch's columns decoded once each, on first
read, or its cycles' fields decoded at once).

A format-3 batch stores each robot-state field's values in a column of their own
(:mod:`beatlog.log.columns`). Replay hands the behaviors, for each cycle, a view of the
system's robot state type that holds the fields read so far in the replay: the batch's
views are decoded a cycle at a time, each one array of the cycle's values of those
fields (:meth:`~beatlog.log.columns.StateColumns.rows`: one decoder call a cycle, not
one a column), the fields of varied width or converted decoded a column at a time; a
field first read later is decoded then (its column, once per batch) and held from the
next batch on. Decoding follows the fields read, not the width of the state.

What a behavior can rely on (README, "Wide robot states"): reading any field gives the
recorded value, its type checked as it is decoded; ``isinstance(state, YourState)``
holds and ``state.__class__`` is your type; your type's methods and properties work.
Equality, ``repr``, copying and pickling act on the whole state. Anything else that
needs the whole struct (encoding it, :func:`msgspec.structs.asdict`, ``replace``,
``type(state) is YourState``) takes :func:`full_state` first.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from itertools import repeat
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.errors import ConversionError, CorruptLogError, SchemaMismatchError
from beatlog.log.columns import StateColumns
from beatlog.log.format import DECODE_ERRORS
from beatlog.replaying.fit.migration import StateConverter

__all__ = ["StateViews", "full_state"]

BATCH = "_beatlog_batch"
"""The attribute of a view that holds its batch."""
INDEX = "_beatlog_index"
"""The attribute of a view that holds where its cycle is in the batch."""


def full_state(state: Any) -> Any:
    """The robot state itself, every field decoded, for a view (:class:`StateViews`);
    any other state as it is."""
    batch = getattr(state, BATCH, None)
    if isinstance(batch, ViewedBatch):
        return batch.whole(getattr(state, INDEX))
    return state


class _Unheld:
    """A field a view does not hold, as an attribute of its class: read, it is decoded
    from its column (and held from the next batch on). A class attribute rather than a
    ``__getattr__``, which would make every attribute read look for it first."""

    __slots__ = ("name",)

    def __init__(self, name: str) -> None:
        self.name = name

    def __get__(self, view: Any, owner: type[Any] | None = None) -> Any:
        if view is None:
            return self
        batch: ViewedBatch = getattr(view, BATCH)
        return batch.miss(getattr(view, INDEX), self.name)


def _view_eq(self: Any, other: Any) -> Any:
    return full_state(self) == full_state(other)


def _view_repr(self: Any) -> str:
    return repr(full_state(self))


def _view_copy(self: Any) -> Any:
    return copy.copy(full_state(self))


def _view_deepcopy(self: Any, memo: dict[int, Any]) -> Any:
    return copy.deepcopy(full_state(self), memo)


def _view_reduce(self: Any) -> Any:
    return full_state(self).__reduce__()


_VIEW_METHODS = {
    "__eq__": _view_eq,
    "__repr__": _view_repr,
    "__copy__": _view_copy,
    "__deepcopy__": _view_deepcopy,
    "__reduce__": _view_reduce,
    "__hash__": None,
}


class StateViews:
    """Views of the system's robot state over format-3 batches, for the replay core.

    ``checking`` is the type each RS_t must fit
    (:func:`~beatlog.replaying.fit.schema.recorded_state_type`): a batch may hold no field it
    lacks, and must hold every one it requires; each column is decoded as the field's
    type there (under its recorded name), and the fields ``convert`` converts are
    turned into the system's as they are decoded.
    """

    def __init__(
        self,
        system_type: type[Any],
        checking: type[Any],
        path: Path,
        convert: StateConverter | None = None,
    ) -> None:
        self.system_type = system_type
        self.checking = checking
        self.path = path
        self.convert = convert
        self.shape = _shape(system_type, checking)
        """What views of these types share in a process: their fields, classes, decoders."""
        self.fields = self.shape.fields
        self.read: dict[str, None] = {}
        """The fields read so far, in the order first read: each view holds them."""
        self._checked: list[str] | None = None
        self._index: dict[str, int] = {}
        self._indexed: list[str] | None = None
        self._plans: dict[
            tuple[str, ...], tuple[list[str], list[int], list[Callable[[Any], list[Any]]]]
        ] = {}
        self._layouts: dict[tuple[bytes, tuple[str, ...]], BatchLayout] = {}
        self._columns: StateColumns | None = None
        self._views: list[Any] = []
        self._first = 0
        self._batch: ViewedBatch | None = None
        self.stale = False
        """Whether a field was first read in the batch the views are of."""

    def view(self, columns: StateColumns, cycle: int) -> Any:
        """RS_t of ``cycle``, one of the batch ``columns`` holds."""
        if columns is not self._columns or self.stale:
            self._open(columns)
        return self._views[cycle - self._first]

    def _open(self, columns: StateColumns) -> None:
        """Check a batch's fields against the type and make its cycles' views (again,
        holding one more field, when a behavior read a field first in this batch)."""
        if columns is self._columns and self._batch is not None:
            batch = self._batch
        else:
            if columns.names is not self._checked:
                self._check(columns)
            batch = self._batch = ViewedBatch(self, columns)
        self.stale = False
        self._columns = columns
        self._first = columns.first_cycle
        self._views = batch.views(tuple(self.read))

    def _check(self, columns: StateColumns) -> None:
        """A batch's fields must be the type's: none it lacks, every one it requires."""
        names = columns.names
        if names is not None:
            unknown = [name for name in names if name not in self.shape.recorded]
            required = {
                info.encode_name for info in self.fields.values() if info.required
            }.difference(names)
            if unknown or required:
                problem = (
                    f"object contains unknown field `{unknown[0]}`"
                    if unknown
                    else f"object missing required field `{sorted(required)[0]}`"
                )
                raise SchemaMismatchError(
                    self.path,
                    f"robot state of cycle {columns.first_cycle} does not fit "
                    f"{self.system_type.__name__}: {problem}",
                )
        self._checked = names

    def index(self, names: list[str] | None) -> dict[str, int]:
        """Each field's column among ``names`` (those of the batch checked last)."""
        if names is not self._indexed:
            self._index = {name: at for at, name in enumerate(names or ())}
            self._indexed = names
            self._plans = {}
            self._layouts = {}
        return self._index

    def plan(
        self, names: list[str] | None, fresh: tuple[str, ...]
    ) -> tuple[list[str], list[int], list[Callable[[Any], list[Any]]]]:
        """Of the fields ``fresh``, those a batch of the columns ``names`` holds, each
        one's column and what decodes it (made once per batch layout)."""
        index = self.index(names)
        found = self._plans.get(fresh)
        if found is None:
            fields = self.fields
            stored = [name for name in fresh if fields[name].encode_name in index]
            at = [index[fields[name].encode_name] for name in stored]
            found = self._plans[fresh] = (stored, at, list(map(self.shape.decoder, stored)))
        return found

    def layout(self, columns: StateColumns, held: tuple[str, ...]) -> BatchLayout:
        """How a batch of ``columns`` gives views holding the fields ``held`` (made once
        per batch layout).

        The fields it stores, unless converted, are decoded a cycle at a time from its
        :meth:`~StateColumns.rows` (those of one width first, in column order), the
        others decoded a column at a time and set on the views; where most of the
        fields stored are of varied width, all are decoded a column at a time, which
        costs less for them."""
        index = self.index(columns.names)
        key = (columns.widths, held)
        found = self._layouts.get(key)
        if found is None:
            fields = self.fields
            widths = columns.widths
            converted = self.convert.fields if self.convert is not None else ()
            stored = [
                (not widths[column], column, name)
                for name in held
                if (column := index.get(fields[name].encode_name)) is not None
                and name not in converted
            ]
            stored.sort()
            varied = sum(of_varied for of_varied, _, _ in stored)
            if 2 * varied > len(stored):
                stored = []
            in_rows = tuple(name for _, _, name in stored)
            taken = set(in_rows)
            rest = tuple(name for name in held if name not in taken)
            if len(self._layouts) >= _MAX_LAYOUTS:
                self._layouts.clear()
            found = self._layouts[key] = BatchLayout(
                [column for of_varied, column, _ in stored if not of_varied],
                [column for of_varied, column, _ in stored if of_varied],
                rest,
                *self.shape.view_class(in_rows, rest),
            )
        return found

    def adopt(self, state: Any, cycle: int) -> Any:
        """A state decoded as :attr:`checking` made the system's, its fields converted.

        :raises beatlog.errors.SchemaMismatchError: a conversion failed (the user's code
            raised, or a value does not fit its field once converted).
        """
        if state.__class__ is not self.system_type:
            state.__class__ = self.system_type
        if self.convert is not None:
            self.converting(cycle, self.convert, state)
        return state

    def converting(self, cycle: int, convert: Callable[..., Any], *values: Any) -> Any:
        """``convert(*values)`` for a robot state of ``cycle``, or a field of it.

        :raises beatlog.errors.SchemaMismatchError: the conversion failed (the user's code
            raised, or a value does not fit its field once converted).
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


class BatchLayout(NamedTuple):
    """How a batch gives its views (:meth:`StateViews.layout`)."""

    columns: list[int]
    """The columns of values of one width decoded a cycle at a time, in the order of
    the views' fields."""
    varied: list[int]
    """The columns of values of varied width decoded a cycle at a time, after them."""
    rest: tuple[str, ...]
    """The fields held decoded a column at a time, after them."""
    view: type[Any]
    """The class of the views."""
    decode: Callable[[bytes], Any]
    """A view decoded from a cycle's array of the values of :attr:`columns` and
    :attr:`varied`."""


class ViewedBatch:
    """One batch's columns as its views read them: each decoded once, on first read."""

    __slots__ = ("columns", "decoded", "index", "views_of")

    def __init__(self, views: StateViews, columns: StateColumns) -> None:
        self.views_of = views
        self.columns = columns
        self.index = views.index(columns.names)
        self.decoded: dict[str, list[Any]] = {}

    def views(self, held: tuple[str, ...]) -> list[Any]:
        """The batch's views, holding the fields ``held``: decoded a cycle at a time,
        each cycle's fields at once, or a column at a time (:meth:`StateViews.layout`).

        :raises beatlog.errors.SchemaMismatchError: a value does not fit its field's type
            (found as decoding the columns in the order read would find it).
        :raises beatlog.errors.CorruptLogError: a column is damaged.
        """
        owner = self.views_of
        layout = owner.layout(self.columns, held)
        if not layout.columns and not layout.varied:
            values = self.held(layout.rest)
            return list(map(layout.view, *values, repeat(self), range(self.columns.count)))
        try:
            views = list(map(layout.decode, self.columns.rows(layout.columns, layout.varied)))
        except (msgspec.ValidationError, *DECODE_ERRORS):
            self.held(held)  # found again, to say where
            raise CorruptLogError(
                owner.path,
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
        decoded yet are decoded together (:meth:`StateColumns.decoded`)."""
        decoded = self.decoded
        fresh = tuple(name for name in names if name not in decoded)
        if fresh:
            views = self.views_of
            stored, at, decoders = views.plan(self.columns.names, fresh)
            found = self.columns.decoded(at, decoders, views.system_type.__name__)
            convert = views.convert
            for name, values in zip(stored, found, strict=True):
                converts = convert is not None and name in convert.fields
                decoded[name] = self._converted(name, values) if converts else values
        return [decoded[name] if name in decoded else self.values(name) for name in names]

    def values(self, name: str) -> list[Any]:
        """Field ``name`` of every cycle of the batch, the system's."""
        found = self.decoded.get(name)
        if found is not None:
            return found
        views = self.views_of
        info = views.fields[name]
        at = self.index.get(info.encode_name)
        count = self.columns.count
        if at is None:  # a field the system gained since the recording
            if info.default_factory is not msgspec.NODEFAULT:
                found = [info.default_factory() for _ in range(count)]
            else:
                found = [info.default] * count
        else:
            decode = views.shape.decoder(name)
            found = self.columns.values(at, decode, views.system_type.__name__)
            if views.convert is not None and name in views.convert.fields:
                found = self._converted(name, found)
        self.decoded[name] = found
        return found

    def _converted(self, name: str, values: list[Any]) -> list[Any]:
        """Recorded values of a field the migration converts, made the system's."""
        views = self.views_of
        convert = views.convert
        assert convert is not None
        first = self.columns.first_cycle
        return [
            views.converting(first + offset, convert.value, name, value)
            for offset, value in enumerate(values)
        ]

    def miss(self, index: int, name: str) -> Any:
        """Field ``name`` of the batch's ``index``-th cycle, read for the first time in
        this batch."""
        views = self.views_of
        if name not in views.read:
            views.read[name] = None
            views.stale = True
        return self.values(name)[index]

    def whole(self, index: int) -> Any:
        """The batch's ``index``-th RS_t decoded whole, the system's."""
        cycle = self.columns.first_cycle + index
        return self.views_of.decode_whole(self.columns.raw_state(cycle), cycle)


_MAX_LAYOUTS = 64


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
        self.recorded = {info.encode_name: info.name for info in self.fields.values()}
        """Each field's name by its encoded name."""
        self.whole: Callable[[bytes], Any] = msgspec.msgpack.Decoder(checking).decode
        """RS_t decoded whole, as ``checking``."""
        namespace = {**_methods(system_type, self.fields), **_VIEW_METHODS}
        self._namespace = {
            **namespace,
            "__class__": system_type,
            "__qualname__": system_type.__qualname__,
        }
        self._views: dict[
            tuple[tuple[str, ...], tuple[str, ...]],
            tuple[type[Any], Callable[[bytes], Any]],
        ] = {}
        self._decoders: dict[str, Callable[[bytes], list[Any]]] = {}

    def view_class(
        self, in_rows: tuple[str, ...], rest: tuple[str, ...]
    ) -> tuple[type[Any], Callable[[bytes], Any]]:
        """The class of views holding the fields ``in_rows`` and ``rest``, and what
        decodes one from an array of the values of ``in_rows`` (each as its field's
        type), ``rest`` set after; without ``in_rows``, views are made positionally."""
        found = self._views.get((in_rows, rest))
        if found is None:
            held = {*in_rows, *rest}
            unheld = {name: _Unheld(name) for name in self.fields if name not in held}
            view = msgspec.defstruct(
                self.system_type.__name__,
                [
                    *((name, self.fields[name].type) for name in in_rows),
                    *((name, Any, None) for name in rest),
                    (BATCH, Any, None),
                    (INDEX, int, 0),
                ],
                module=self.system_type.__module__,
                namespace={**self._namespace, **unheld},
                array_like=True,
                gc=False,
                weakref=False,
            )
            if len(self._views) >= _MAX_LAYOUTS:
                self._views.clear()
            found = self._views[in_rows, rest] = (view, msgspec.msgpack.Decoder(view).decode)
        return found

    def decoder(self, name: str) -> Callable[[bytes], list[Any]]:
        """What decodes a column of field ``name`` (a msgpack array) as the field's type."""
        found = self._decoders.get(name)
        if found is None:
            kind = self.fields[name].type
            found = self._decoders[name] = msgspec.msgpack.Decoder(list[kind]).decode  # type: ignore[valid-type]
        return found


_SHAPES: dict[tuple[type[Any], type[Any]], _Shape] = {}
_MAX_SHAPES = 64


def _shape(system_type: type[Any], checking: type[Any]) -> _Shape:
    """The :class:`_Shape` of the pair, made on first need (at most 64 kept)."""
    found = _SHAPES.get((system_type, checking))
    if found is None:
        if len(_SHAPES) >= _MAX_SHAPES:
            _SHAPES.clear()
        found = _SHAPES[system_type, checking] = _Shape(system_type, checking)
    return found


def _methods(system_type: type[Any], fields: dict[str, Any]) -> dict[str, Any]:
    """The user's own methods, properties and class attributes of a robot state type,
    for its views."""
    found: dict[str, Any] = {}
    for klass in reversed(system_type.__mro__):
        if klass.__module__.startswith("msgspec") or klass is object:
            continue
        for name, value in vars(klass).items():
            if name.startswith(("__", "_beatlog")) or name in fields:
                continue
            found[name] = value
    return found

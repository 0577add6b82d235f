"""One format-3 batch as the views of its cycles read it (:mod:`beatlog.replay.view`):
its columns decoded once each, on first read, or its cycles' fields decoded at once."""

from __future__ import annotations

from collections.abc import Callable
from itertools import repeat
from typing import TYPE_CHECKING, Any, NamedTuple

import msgspec

from beatlog.errors import ConversionError, CorruptLogError, SchemaMismatchError
from beatlog.log.columns import StateColumns
from beatlog.log.format import DECODE_ERRORS

if TYPE_CHECKING:
    from beatlog.replay.view import StateViews

__all__ = ["BATCH", "INDEX", "BatchLayout", "ViewedBatch"]

BATCH = "_beatlog_batch"
"""The attribute of a view that holds its batch."""
INDEX = "_beatlog_index"
"""The attribute of a view that holds where its cycle is in the batch."""


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
        convert = self.views_of.convert
        assert convert is not None
        first = self.columns.first_cycle
        converted = []
        for offset, value in enumerate(values):
            try:
                converted.append(convert.value(name, value))
            except ConversionError as exc:
                error = SchemaMismatchError(
                    self.views_of.path, f"robot state of cycle {first + offset}: {exc}"
                )
                error.user_traceback = exc.user_traceback
                raise error from None
        return converted

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

"""Signals of a timeline: numeric robot-state fields, each bucket's minimum and maximum,
read from the log without running any code."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.analysis.grid import TimeGrid
from beatlog.errors import CorruptLogError, FieldError
from beatlog.log.format import DECODE_ERRORS, CycleRecord

__all__ = ["Sampler"]

DEFAULT_FIELDS = 4
"""How many numeric robot-state fields a timeline samples when none are named."""


class Signal(NamedTuple):
    """A numeric robot-state field: each bucket's minimum and maximum, in time order."""

    field: str
    time_ns: tuple[int, ...]
    value: tuple[float, ...]
    flag: bool = False
    """Whether the field is a boolean, drawn as 0 (False) and 1 (True)."""


class _Buckets:
    """One signal's lowest and highest value in each bucket, each with its robot time:
    ``[low_ns, low, high_ns, high]``, or None where the bucket holds no number."""

    def __init__(self, grid: TimeGrid) -> None:
        self.kept: list[list[Any] | None] = [None] * grid.count

    def add(self, index: int, time_ns: int, value: float) -> None:
        kept = self.kept[index]
        if kept is None:
            if not math.isnan(value):  # NaN is no point, and compares as neither low nor high
                self.kept[index] = [time_ns, value, time_ns, value]
        elif value < kept[1]:  # on a tie the earlier point stays
            kept[0:2] = time_ns, value
        elif value > kept[3]:
            kept[2:4] = time_ns, value

    def merge(self, factor: int) -> None:
        """Merge each run of ``factor`` neighbours into one: the buckets grew as long."""
        kept, self.kept = self.kept, [None] * len(self.kept)
        for index, bucket in enumerate(kept):
            if bucket is not None:
                self.add(index // factor, bucket[0], bucket[1])
                self.add(index // factor, bucket[2], bucket[3])

    def points(self) -> list[tuple[int, float]]:
        """Each bucket's lowest and highest value with its robot time, in time order, each
        point once."""
        points: list[tuple[int, float]] = []
        for kept in self.kept:
            if kept is not None:
                low, high = (kept[0], kept[1]), (kept[2], kept[3])
                points.extend([low] if low == high else sorted([low, high]))
        return points


class Sampler:
    """Keeps numeric robot-state fields in buckets, read from the log without any code."""

    def __init__(self, path: Path, fields: Sequence[str] | None, grid: TimeGrid) -> None:
        self.path = path
        self.cycles = 0
        self._asked = fields
        self._grid = grid
        self._fields: list[str] | None = None
        self._flags: list[bool] = []
        self._buckets: list[_Buckets] = []
        self._decode: Any = msgspec.msgpack.Decoder().decode
        self._seen = 0

    @property
    def held(self) -> int:
        return sum(len(buckets.kept) for buckets in self._buckets)

    def add(self, record: CycleRecord, time_ns: int) -> None:
        if self._fields is None:
            self._start(self._decoded(record))
        inside = self._grid.contains(time_ns)
        if inside:
            self.cycles += 1
        if inside and self._buckets:
            values = msgspec.structs.astuple(self._decoded(record))
            index = self._grid.index(time_ns)
            for buckets, value in zip(self._buckets, values, strict=True):
                if isinstance(value, int | float):
                    buckets.add(index, time_ns, float(value))
        self._seen += 1

    def _decoded(self, record: CycleRecord) -> Any:
        try:
            return self._decode(record.robot_state)
        except DECODE_ERRORS as exc:
            raise CorruptLogError(
                self.path, f"damaged robot state in cycle {self._seen}: {exc}"
            ) from None

    def _start(self, state: Any) -> None:
        """Choose the fields from the first robot state; decode just those from now on."""
        if not isinstance(state, dict):
            state = {}
        fields = self._fields = self._choose(state)
        self._flags = [isinstance(state[name], bool) for name in fields]
        self._buckets = [_Buckets(self._grid) for _ in fields]
        self._grid.on_widen.extend(buckets.merge for buckets in self._buckets)
        sampled = msgspec.defstruct(
            "Sampled",
            [(f"f{index}", Any, None) for index in range(len(fields))],
            rename={f"f{index}": name for index, name in enumerate(fields)},
        )
        self._decode = msgspec.msgpack.Decoder(sampled).decode

    def _choose(self, state: dict[str, Any]) -> list[str]:
        numeric = [name for name, value in state.items() if isinstance(value, int | float)]
        if self._asked is None:
            return numeric[:DEFAULT_FIELDS]
        known = ", ".join(numeric) or "none"
        for name in self._asked:
            if name not in state:
                raise FieldError(
                    f"{self.path}: the robot state has no field {name!r} (numeric fields: {known})"
                )
            if name not in numeric:
                raise FieldError(
                    f"{self.path}: robot-state field {name!r} is a {type(state[name]).__name__}, "
                    f"not a number (numeric fields: {known})"
                )
        return list(dict.fromkeys(self._asked))

    def signals(self) -> tuple[Signal, ...]:
        """Each field's points so far."""
        signals = []
        for name, flag, buckets in zip(self._fields or (), self._flags, self._buckets, strict=True):
            points = buckets.points()
            times = tuple(time_ns for time_ns, _ in points)
            signals.append(Signal(name, times, tuple(value for _, value in points), flag))
        return tuple(signals)

"""The held values of departing output fields, spliced into each recorded cycle's outputs.

Against a baseline of departures (:mod:`beatlog.replay.departures`), an output field
that departs holds its approved value from a cycle on, whatever was recorded: a cycle's
expected outputs are its recorded ones with the held values in place. A robot's
recorded outputs keep their shape from cycle to cycle (the same fields in the same
order, each value the same type) while the numbers in them change, so
:class:`HeldOutputs` learns a shape once, by decoding a cycle's outputs, and splices the
held values into the bytes of every later cycle of that shape without decoding them.

A shape (a *layout*) fixes the bits of the outputs that must recur: the map header,
every key, every value but the 64 bits of a float (its type byte stays) and the low
bits of an integer that fits in its type byte. Outputs of the layout's size with those
bits decode to the same fields, in the same order, each the same type, only those
numbers differing (any such bits are a number, encoded as beatlog encodes it), so the
held values' encodings spliced into their bytes give exactly what decoding them,
applying the held values and encoding the result would. Outputs of no
known layout are decoded (damaged ones are an error in their cycle) and give a new
layout where they encode back to their own bytes, as beatlog writes them.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any, NamedTuple

import msgspec

from beatlog.log.format import EMPTY_MAP, payload_encoder
from beatlog.log.payload import decode_outputs, decode_part
from beatlog.replay.departures import apply_outputs, hold
from beatlog.replay.expectation import ABSENT, TracedOutput

__all__ = ["LAYOUTS_PER_SIZE", "HeldOutputs"]

LAYOUTS_PER_SIZE = 4
"""The layouts kept for outputs of one size, the latest first: a robot's outputs take a
few shapes, and outputs whose shapes never recur cost no more than trying these."""


class _Field(NamedTuple):
    """Where an output field lies in the recorded bytes."""

    key: int
    value: int
    end: int


class _Splice(NamedTuple):
    """How the held values go into outputs of a layout: where none changes the size,
    the bits ``keep`` keeps of the recorded ones, ORed with ``bits``; otherwise the
    recorded bytes ``cuts``, each after the bytes in ``fills`` of its place (the last
    fill follows the last cut)."""

    keep: int
    bits: int
    cuts: tuple[slice, ...]
    fills: tuple[bytes, ...]


class _Layout:
    """A shape of recorded outputs (see the module docstring), with its splice of the
    held values made for the time they last changed (``generation``)."""

    __slots__ = ("count", "fields", "fixed", "generation", "mask", "size", "splice")

    def __init__(self, data: bytes, mask: int, fields: dict[str, _Field]) -> None:
        self.size = len(data)
        self.mask = mask
        self.fixed = int.from_bytes(data, "big") & mask
        self.count = len(fields)
        self.fields = fields
        self.generation = -1
        self.splice = _Splice(0, 0, (), ())


class HeldOutputs:
    """The values departing output fields hold, from a baseline's output lines, put
    into each recorded cycle's outputs (``path`` names the log in errors)."""

    def __init__(self, path: Path) -> None:
        self._path = path
        self._encode = payload_encoder().encode
        self._held: dict[str, Any] = {}
        self._generation = 0
        """How many times the held values changed: a layout's splice is for one time."""
        self._layouts: dict[int, list[_Layout]] = {}
        """The layouts learned, by the size of their outputs."""

    def hold(self, lines: Iterable[TracedOutput]) -> bool:
        """Take a cycle's output lines; whether any field holds a value now."""
        hold(self._held, lines)
        self._generation += 1
        return bool(self._held)

    def expected(self, recorded: msgspec.Raw, cycle: int) -> msgspec.Raw:
        """Cycle ``cycle``'s recorded outputs with the held values in place.

        :raises beatlog.errors.CorruptLogError: they are damaged.
        """
        data = bytes(recorded)
        number = int.from_bytes(data, "big")
        for layout in self._layouts.get(len(data), ()):
            if (number ^ layout.fixed) & layout.mask == 0:
                if layout.generation != self._generation:
                    layout.splice = self._splice(layout)
                    layout.generation = self._generation
                keep, bits, cuts, fills = layout.splice
                if not cuts:
                    return msgspec.Raw(((number & keep) | bits).to_bytes(layout.size, "big"))
                parts = [fills[0]]
                for cut, fill in zip(cuts, fills[1:], strict=True):
                    parts += (data[cut], fill)
                return msgspec.Raw(b"".join(parts))
        return self._decoded(data, cycle)

    def _decoded(self, data: bytes, cycle: int) -> msgspec.Raw:
        """Outputs of no known layout, decoded, held values applied and encoded again;
        their layout learned where they encode back to their own bytes."""
        values = decode_part(self._path, data, decode_outputs, "outputs", cycle)
        encode = self._encode
        if encode(values) == data:
            mask = bytearray(b"\xff" * len(data))
            fields: dict[str, _Field] = {}
            at = len(_map_header(len(values)))
            for name, value in values.items():
                key = at
                start = at = at + len(encode(name))
                at += len(encode(value))
                fields[name] = _Field(key, start, at)
                if value.__class__ is float:  # a type byte, then any 64 bits
                    mask[start + 1 : at] = bytes(at - start - 1)
                elif value.__class__ is int and at - start == 1:  # its value in the low bits
                    mask[start] = 0x80 if value >= 0 else 0xE0
            kept = self._layouts.setdefault(len(data), [])
            kept.insert(0, _Layout(data, int.from_bytes(mask, "big"), fields))
            del kept[LAYOUTS_PER_SIZE:]
        outputs = apply_outputs(values, self._held)
        return msgspec.Raw(encode(outputs)) if outputs else EMPTY_MAP

    def _splice(self, layout: _Layout) -> _Splice:
        """How the held values go into outputs of ``layout``, as :func:`apply_outputs`
        puts them: in place, an absent one's field dropped, a new field appended."""
        encode = self._encode
        count = layout.count
        replaced: list[tuple[int, int, bytes]] = []
        appended: list[bytes] = []
        for name, value in self._held.items():
            field = layout.fields.get(name)
            if value is ABSENT:
                if field is not None:
                    replaced.append((field.key, field.end, b""))
                    count -= 1
            elif field is None:
                appended += (encode(name), encode(value))
                count += 1
            else:
                replaced.append((field.value, field.end, encode(value)))
        replaced.sort()
        size = layout.size
        if not appended and all(len(fill) == end - start for start, end, fill in replaced):
            keep, bits = (1 << 8 * size) - 1, 0
            for start, end, fill in replaced:
                shift = 8 * (size - end)
                keep &= ~(((1 << 8 * (end - start)) - 1) << shift)
                bits |= int.from_bytes(fill, "big") << shift
            return _Splice(keep, bits, (), ())
        at = len(_map_header(layout.count))
        cuts: list[slice] = []
        fills = [_map_header(count)]
        for start, end, fill in replaced:
            cuts.append(slice(at, start))
            fills.append(fill)
            at = end
        cuts.append(slice(at, size))
        fills.append(b"".join(appended))
        return _Splice(0, 0, tuple(cuts), tuple(fills))


def _map_header(count: int) -> bytes:
    """The msgpack header of a map of ``count`` entries."""
    if count < 16:
        return bytes([0x80 | count])
    if count < 1 << 16:
        return b"\xde" + count.to_bytes(2, "big")
    return b"\xdf" + count.to_bytes(4, "big")

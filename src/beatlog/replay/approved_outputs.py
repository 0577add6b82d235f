"""Approved outputs: the values a baseline's output lines give, put into the recorded
cycles' outputs.

Against a baseline of departures (:mod:`beatlog.replay.departures`), an output field
that departs holds its approved value from a cycle on, whatever was recorded.
:class:`ApprovedOutputs` puts them into a run of records at a time: most cycles repeat
the last one's recorded outputs and take its expected ones; the others are decoded,
given the approved values and encoded again.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import msgspec

from beatlog.errors import CorruptLogError
from beatlog.log.format import DECODE_ERRORS, EMPTY_MAP, CycleRecord, payload_encoder
from beatlog.log.payload import decode_outputs
from beatlog.replay.departures import hold
from beatlog.replay.expectation import ABSENT, TracedOutput

__all__ = ["ApprovedOutputs"]


class ApprovedOutputs:
    """The approved values departing output fields hold, from a baseline's output lines,
    put into the recorded cycles' outputs (``path`` names the log in errors)."""

    def __init__(self, path: Path) -> None:
        self._path = path
        self._encode = payload_encoder().encode
        self._held: dict[str, Any] = {}
        self._values: dict[str, Any] = {}
        """The held values of the fields output, in the order they were held."""
        self._absent: tuple[str, ...] = ()
        """The fields held absent."""
        self._last: tuple[msgspec.Raw | None, msgspec.Raw] = (None, EMPTY_MAP)
        """The last cycle's recorded outputs and expected ones: most cycles repeat them."""

    def hold(self, lines: Iterable[TracedOutput]) -> bool:
        """Take a cycle's output lines; whether any field holds a value now."""
        held = self._held
        hold(held, lines)
        self._values = {name: value for name, value in held.items() if value is not ABSENT}
        self._absent = tuple(name for name, value in held.items() if value is ABSENT)
        self._last = (None, EMPTY_MAP)
        return bool(held)

    def put(self, records: Sequence[CycleRecord], cycle: int) -> None:
        """Put the expected outputs into ``records``, cycles ``cycle`` on, in place of
        the recorded ones.

        :raises beatlog.errors.CorruptLogError: a cycle's outputs are damaged.
        """
        recorded, expected = self._last
        values, absent, encode = self._values, self._absent, self._encode
        for record in records:
            outputs = record.outputs
            if outputs != recorded:
                recorded = outputs
                try:
                    decoded = decode_outputs(outputs)
                except DECODE_ERRORS as exc:
                    at = cycle + next(i for i, damaged in enumerate(records) if damaged is record)
                    raise CorruptLogError(
                        self._path, f"damaged outputs in cycle {at}: {exc}"
                    ) from None
                decoded.update(values)
                for name in absent:
                    decoded.pop(name, None)
                expected = msgspec.Raw(encode(decoded)) if decoded else EMPTY_MAP
            record.outputs = expected
        self._last = (recorded, expected)

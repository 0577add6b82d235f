"""Held outputs: the recorded outputs with the held values in place, bit for bit as
decoding, applying and encoding them gives, each shape decoded once."""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import msgspec
import pytest

from beatlog.errors import CorruptLogError
from beatlog.log import payload
from beatlog.log.format import payload_encoder
from beatlog.replay import held_outputs
from beatlog.replay.departures import apply_outputs
from beatlog.replay.expectation import ABSENT, AS_RECORDED, TracedOutput
from beatlog.replay.held_outputs import HeldOutputs

LOG = Path("walk.beatlog")
ENCODE = payload_encoder().encode


def as_logged(outputs: dict[str, Any]) -> msgspec.Raw:
    return msgspec.Raw(ENCODE(outputs))


WALKING = [
    as_logged({"happiness": 41, "motion": "walk", "speed": 0.15, "turn": 0.024}),
    as_logged({"happiness": 42, "motion": "walk", "speed": 0.15, "turn": -0.0}),
    as_logged({"happiness": -7, "motion": "walk", "speed": float("nan"), "turn": 1e300}),
    as_logged({"happiness": 300, "motion": "walk", "speed": 0.18, "turn": 0.0}),
    as_logged({"happiness": 301, "motion": "walk", "speed": 0.18, "turn": 0.5}),
    as_logged({"happiness": 3, "motion": "lie"}),
    as_logged({"happiness": 4, "motion": "lie"}),
    as_logged({"happiness": 4, "motion": "walk", "speed": [0.1, 0.2], "turn": True}),
    as_logged({"happiness": 4, "motion": "walk", "speed": [0.1, 0.3], "turn": None}),
    as_logged({"happiness": 5, "motion": "sit", "speed": 0.0, "turn": 0.0}),
    as_logged({f"f{n}": float(n) for n in range(16)}),
    as_logged({f"f{n}": float(n + 1) for n in range(16)}),
    msgspec.Raw(b"\x81\xa5speed\xca" + struct.pack(">f", 0.5)),  # a float32
    msgspec.Raw(b"\x81\xa5speed\xcc\x05"),  # 5, not in its shortest form
    msgspec.Raw(b"\x82\xa5speed\x01\xa5speed\x02"),  # a field twice
    as_logged({}),
]
"""Recorded outputs, each shape more than once where numbers change."""

HELD: list[list[tuple[str, Any]]] = [
    [],
    [("turn", 0.0)],  # the same size as the recorded floats
    [("happiness", 47), ("turn", 0.0)],
    [("happiness", 200)],  # longer than a fixint
    [("turn", ABSENT)],
    [("turn", AS_RECORDED), ("speed", ABSENT), ("motion", "run")],
    [("speed", 0.0), ("wag", [1, 2])],  # a field the recording lacks
    [("f3", ABSENT), ("f4", -1), ("happiness", AS_RECORDED), ("motion", AS_RECORDED)],
]
"""The held values as output lines take them, one set after another."""


def reference(recorded: msgspec.Raw, held: dict[str, Any]) -> bytes:
    """Decoding, applying the held values and encoding them again."""
    return ENCODE(apply_outputs(msgspec.msgpack.decode(recorded), held))


def lines(held: list[tuple[str, Any]]) -> list[TracedOutput]:
    return [TracedOutput(0, 0, field, value) for field, value in held]


def test_held_values_in_place_bit_for_bit_as_decoding_and_encoding_gives() -> None:
    outputs = HeldOutputs(LOG)
    held: dict[str, Any] = {}
    got, wanted = [], []
    for cycle, changes in enumerate(HELD):
        outputs.hold(lines(changes))
        for field, value in changes:
            if value is AS_RECORDED:
                held.pop(field, None)
            else:
                held[field] = value
        for recorded in [*WALKING, *WALKING]:
            got.append(bytes(outputs.expected(recorded, cycle)))
            wanted.append(reference(recorded, held))
    assert got == wanted


def test_each_shape_is_decoded_once(monkeypatch: pytest.MonkeyPatch) -> None:
    decoded: list[bytes] = []

    def decode(data: bytes | msgspec.Raw) -> dict[str, Any]:
        decoded.append(bytes(data))
        return payload.decode_outputs(data)

    monkeypatch.setattr(held_outputs, "decode_outputs", decode)
    outputs = HeldOutputs(LOG)
    outputs.hold(lines([("turn", 0.0)]))
    expected = [bytes(outputs.expected(recorded, 3)) for recorded in WALKING[:7]]

    # Outputs 1 and 6 have the shapes of 0 and 5; an integer past its type byte (3, 4)
    # has a shape of its own.
    assert decoded == [bytes(WALKING[n]) for n in (0, 2, 3, 4, 5)]
    assert expected == [reference(recorded, {"turn": 0.0}) for recorded in WALKING[:7]]


def test_whether_a_field_holds_a_value() -> None:
    outputs = HeldOutputs(LOG)
    assert [
        outputs.hold(lines([("turn", 0.0)])),
        outputs.hold(lines([("speed", ABSENT)])),
        outputs.hold(lines([("turn", AS_RECORDED)])),
        outputs.hold(lines([("speed", AS_RECORDED)])),
    ] == [True, True, True, False]


def test_damaged_outputs_are_an_error_in_their_cycle() -> None:
    outputs = HeldOutputs(LOG)
    outputs.hold(lines([("turn", 0.0)]))
    with pytest.raises(CorruptLogError) as raised:
        outputs.expected(msgspec.Raw(b"\x82\xa5speed\xcb\x00"), 12)
    assert str(raised.value) == f"{LOG}: damaged outputs in cycle 12: Input data was truncated"

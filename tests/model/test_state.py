"""The robot state type: a wide state built positionally, in time linear in its width,
is the state built by keywords, to the byte."""

from __future__ import annotations

import msgspec
import pytest

from beatlog.log.format import payload_encoder
from beatlog.model.state import RobotState

FIELDS = [(f"reading_{index:03d}", float, 0.0) for index in range(300)]
Wide = msgspec.defstruct("Wide", FIELDS, bases=(RobotState,))
WideByName = msgspec.defstruct("WideByName", FIELDS, bases=(RobotState,), kw_only=True)


def test_a_wide_state_built_positionally_is_the_one_built_by_keywords() -> None:
    values = [index / 7 for index in range(len(FIELDS))]
    by_name = dict(zip(Wide.__struct_fields__, values, strict=True))
    positional = Wide(*values)
    assert positional == Wide(**by_name) == msgspec.convert(by_name, Wide)
    encode = payload_encoder().encode
    assert (
        encode(positional)
        == encode(WideByName(**by_name))
        == encode(msgspec.convert(by_name, WideByName))
    )


def test_only_a_state_declared_without_kw_only_takes_its_fields_by_position() -> None:
    with pytest.raises(TypeError, match="Extra positional arguments provided"):
        WideByName(1.0)

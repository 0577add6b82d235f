"""The type a log's cycles must fit: the system's robot state type with every field the
log recorded required, under the names and types the log holds them."""

from __future__ import annotations

from typing import Any

import msgspec

from beatlog.model.state import RobotState, state_schema
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.fit.schema import recorded_state_type
from tests.crafting import session_header


class Recorded(RobotState, kw_only=True):
    """The robot state an older log recorded: no battery yet."""

    distance: float = 1.0
    reading: float = 0.0


class Full(RobotState, kw_only=True):
    """The robot state a newer log recorded."""

    distance: float = 1.0
    reading: float = 0.0
    battery: float = 1.0


CYCLES = [
    {"distance": 2.0, "reading": 0.5},
    {"distance": 2.0, "reading": 0.5, "battery": 0.25},
    {"reading": 0.5},
    {"distance": "2 m", "reading": 0.5},
]
"""Robot states as cycles might hold them: fitting one log or another, or none."""


def decoded(state_type: type[Any], payload: bytes) -> Any:
    """RS_t decoded as ``state_type``, or the name of the error that refused it."""
    try:
        return msgspec.structs.asdict(msgspec.msgpack.decode(payload, type=state_type))
    except msgspec.ValidationError:
        return "ValidationError"


def test_the_type_to_fit_made_again_decodes_as_the_one_first_made() -> None:
    """The type is made once per robot state type, fields recorded and migration (for
    speed: replaying many logs of one robot makes one): pinned, each made again decodes
    every cycle as the one first made, through logs and a migration in turn."""
    current = msgspec.defstruct(  # a type new to the process: its first types are made
        "Full",
        [("distance", float, 1.0), ("reading", float, 0.0), ("battery", float, 1.0)],
        bases=(RobotState,),
        kw_only=True,
    )
    older = session_header(robot_state_schema=state_schema(Recorded))
    newer = session_header(robot_state_schema=state_schema(Full))
    converted = StateMigration(conversions={"distance": "tests.systems:centimetres"})
    cases = [(older, StateMigration()), (newer, StateMigration()), (older, converted)]
    payloads = [msgspec.msgpack.encode(cycle) for cycle in CYCLES]
    rounds = [
        [
            [decoded(recorded_state_type(header, current, migration), p) for p in payloads]
            for header, migration in cases
        ]
        for _ in range(2)
    ]
    assert rounds[0] == rounds[1]
    fits = [[outcome != "ValidationError" for outcome in case] for case in rounds[0]]
    assert fits == [
        [True, True, False, False],
        [False, True, False, False],
        [True, True, False, True],
    ]

"""One cycle (update, then observe): robot time advances by the heartbeat, the behaviors
update from the robot state, and their state changes come back in catalogue order."""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import pytest

from beatlog.model.behavior import Behavior, BehaviorState
from beatlog.model.context import Context, Outputs
from beatlog.model.cycle import CycleExecutor, Update, find_changes, state_reader
from beatlog.model.random import Draw, RecordingRandom
from tests.conftest import PERIOD_NS, Probe


class Flag:
    """A behavior whose state the panel sets."""

    def __init__(self, state: BehaviorState) -> None:
        self.state = state


class Seen(NamedTuple):
    """What the system saw of the context while it updated."""

    cycle: int
    time_ns: int
    dt_ns: int
    outputs: Outputs


class Panel:
    """A system whose cycle ``t`` sets the states in ``states[t]`` (in the order given)
    and emits ``outputs[t]``; it remembers what it saw of the context."""

    def __init__(
        self,
        states: list[dict[str, BehaviorState]],
        outputs: list[Outputs] | None = None,
    ) -> None:
        self.flags = {"first": Flag("idle"), "second": Flag("idle"), "third": Flag("idle")}
        self.states = states
        self.outputs = outputs or [{} for _ in states]
        self.seen: list[Seen] = []

    @property
    def robot_state(self) -> type[Probe]:
        return Probe

    @property
    def behaviors(self) -> Mapping[str, Behavior]:
        return self.flags

    def update(self, state: Probe, context: Context) -> None:
        self.seen.append(Seen(context.cycle, context.time_ns, context.dt_ns, dict(context.outputs)))
        for name, value in self.states[context.cycle].items():
            self.flags[name].state = value
        for name, value in self.outputs[context.cycle].items():
            context.emit(name, value)


def run(panel: Panel, intervals: list[int]) -> list[list[tuple[int, BehaviorState, BehaviorState]]]:
    executor = CycleExecutor(panel, RecordingRandom(seed=1))
    return [executor.step(interval, Probe()) for interval in intervals]


def test_robot_time_advances_by_each_heartbeat_interval() -> None:
    panel = Panel([{}, {}, {}])
    intervals = [PERIOD_NS, PERIOD_NS + 1_000, PERIOD_NS - 2_000]

    run(panel, intervals)

    assert [(seen.cycle, seen.time_ns, seen.dt_ns) for seen in panel.seen] == [
        (0, PERIOD_NS, PERIOD_NS),
        (1, 2 * PERIOD_NS + 1_000, PERIOD_NS + 1_000),
        (2, 3 * PERIOD_NS - 1_000, PERIOD_NS - 2_000),
    ]


def test_state_changes_come_in_catalogue_order_whatever_order_they_happened_in() -> None:
    panel = Panel([{"third": "turning", "first": "near"}])

    (changes,) = run(panel, [PERIOD_NS])

    assert changes == [(0, "idle", "near"), (2, "idle", "turning")]


def test_a_state_set_to_an_equal_value_is_no_change() -> None:
    panel = Panel([{"first": "near"}, {"first": "".join(["ne", "ar"])}, {"second": "idle"}])

    changes = run(panel, [PERIOD_NS] * 3)

    assert changes == [[(0, "idle", "near")], [], []]


def test_a_change_is_measured_from_the_state_after_the_previous_cycle() -> None:
    panel = Panel([{"first": "near"}, {"first": "idle"}, {"first": "near", "second": "far"}])

    changes = run(panel, [PERIOD_NS] * 3)

    assert changes == [
        [(0, "idle", "near")],
        [(0, "near", "idle")],
        [(0, "idle", "near"), (1, "idle", "far")],
    ]


def test_outputs_start_empty_in_every_cycle() -> None:
    panel = Panel([{}, {}, {}], outputs=[{"speed": 0.5}, {}, {"turn": 0.1}])
    executor = CycleExecutor(panel, RecordingRandom(seed=1))

    after = []
    for _ in range(3):
        executor.step(PERIOD_NS, Probe())
        after.append(dict(executor.context.outputs))

    assert [seen.outputs for seen in panel.seen] == [{}, {}, {}]
    assert after == [{"speed": 0.5}, {}, {"turn": 0.1}]


def test_random_numbers_drawn_in_a_cycle_come_from_the_source_the_executor_was_given() -> None:
    random = RecordingRandom(seed=3)

    class Rolling(Panel):
        def update(self, state: Probe, context: Context) -> None:
            context.actor = 2
            self.flags["third"].state = context.random.randint(1, 6)

    panel = Rolling([{}])
    changes = CycleExecutor(panel, random).step(PERIOD_NS, Probe())

    (draw,) = random.take()
    assert draw == Draw(2, "randint", draw.value, (1, 6))
    assert changes == [(2, "idle", draw.value)]


def test_a_paused_update_is_handed_over_once_with_the_context_of_its_cycle() -> None:
    panel = Panel([{}, {"first": "near"}, {"second": "far"}])
    executor = CycleExecutor(panel, RecordingRandom(seed=1))
    paused: list[tuple[int, int, int]] = []

    def pause(update: Update, state: Probe, context: Context) -> None:
        paused.append((context.cycle, context.time_ns, context.dt_ns))
        update(state, context)

    executor.step(PERIOD_NS, Probe())
    executor.pause_next_update(pause)
    changes = [executor.step(PERIOD_NS + 1_000, Probe()), executor.step(PERIOD_NS, Probe())]

    assert paused == [(1, 2 * PERIOD_NS + 1_000, PERIOD_NS + 1_000)]
    assert changes == [[(0, "idle", "near")], [(1, "idle", "far")]]
    assert [seen.cycle for seen in panel.seen] == [0, 1, 2]


class Computed:
    """A behavior whose state is a property."""

    def __init__(self) -> None:
        self.level = 0

    @property
    def state(self) -> BehaviorState:
        return "high" if self.level > 1 else "low"


def test_the_states_are_read_in_catalogue_order_as_they_are_now() -> None:
    first, second, computed = Flag("idle"), Flag(3), Computed()
    read = state_reader([first, second, computed])
    assert read() == ["idle", 3, "low"]
    first.state, computed.level = None, 2
    assert read() == [None, 3, "high"]
    assert read() is not read()  # a new list each time
    assert state_reader([])() == []


class Slotted:
    __slots__ = ("state",)

    def __init__(self, state: BehaviorState) -> None:
        self.state = state


@pytest.mark.parametrize("size", [1, 2, 17, 300])
def test_the_written_out_reader_reads_what_a_loop_over_the_catalogue_reads(size: int) -> None:
    """The reader's source is written out for the catalogue's size (a speed trick): pinned
    to a plain loop over catalogues of every kind of state, changing between reads."""
    kinds = (Flag, Slotted)
    behaviors: list[Behavior] = [
        Computed() if index % 3 == 2 else kinds[index % 3](index) for index in range(size)
    ]
    read = state_reader(behaviors)
    for level in range(3):
        for index, behavior in enumerate(behaviors):
            if isinstance(behavior, Computed):
                behavior.level = level
            elif index % 2 == level % 2:
                behavior.state = f"{index} at {level}"  # type: ignore[misc]
        assert read() == [behavior.state for behavior in behaviors]


@pytest.mark.parametrize("size", [4, 32, 33, 100])
def test_the_finder_reports_each_change_in_catalogue_order_and_keeps_what_it_saw(
    size: int,
) -> None:
    seen: list[BehaviorState] = ["idle"] * size
    now = list(seen)
    changed = sorted({0, size // 2, size - 1})
    for index in changed:
        now[index] = f"busy {index}"
    now[1] = "".join(["id", "le"])  # equal to the one seen, another object

    changes = find_changes(now, seen)

    assert changes == [(index, "idle", f"busy {index}") for index in changed]
    assert seen == now
    assert seen[1] is not now[1]  # the state seen first is kept
    assert find_changes(now, seen) == []


def test_a_state_equal_to_the_one_seen_is_no_change_and_the_one_seen_stays() -> None:
    seen: list[BehaviorState] = [1]
    assert find_changes([True], seen) == []
    (change,) = find_changes([2], seen)
    assert change == (0, 1, 2)
    assert type(change[1]) is int  # the 1 seen first, not the True seen since


def test_each_cycle_reports_what_the_finder_finds_of_the_same_states() -> None:
    """The executor skips the finder where the states compare equal as a list: pinned to
    the finder itself over cycles that change nothing, change a state to an equal value
    (another object, another type), swap two states, and set a state to None twice."""
    script: list[dict[str, BehaviorState]] = [
        {},
        {"first": "near"},
        {"first": "".join(["ne", "ar"])},
        {"first": "idle", "third": "near"},  # swapped: the same states in other places
        {"second": 1},
        {"second": True},
        {"third": None},
        {"third": None},
        {},
    ]
    panel = Panel(script)
    executor = CycleExecutor(panel, RecordingRandom(seed=1))
    read = state_reader(list(panel.flags.values()))
    seen = read()
    stepped, found = [], []
    for _ in script:
        stepped.append(executor.step(PERIOD_NS, Probe()))
        found.append(find_changes(read(), seen))
    assert stepped == found
    assert [len(changes) for changes in stepped] == [0, 1, 0, 2, 1, 0, 1, 0, 0]

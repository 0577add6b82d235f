"""Each of the dog's behaviors reacts to what it should, and the arbiter ranks them."""

from __future__ import annotations

from collections.abc import Iterable

import pytest

from beatlog.model.context import Outputs
from beatlog.model.cycle import CycleExecutor
from beatlog.model.random import RecordingRandom
from beatlog_examples.dog.behaviors import CHANGES, DogState, Tuning, system

PERIOD_NS = 30_000_000


class Run:
    """Steps the dog's system through robot states, one 30 ms heartbeat each."""

    def __init__(self, tuning: Tuning | None = None) -> None:
        self.system = system(tuning)
        self.random = RecordingRandom(1)
        self.executor = CycleExecutor(self.system, self.random)
        self.outputs: Outputs = {}

    def feed(self, state: DogState, cycles: int = 1) -> Outputs:
        for _ in range(cycles):
            self.executor.step(PERIOD_NS, state)
            self.outputs = dict(self.executor.context.outputs)
        return self.outputs

    def state(self, behavior: str) -> object:
        return self.system.behaviors[behavior].state

    def winner(self) -> object:
        return self.system.behaviors["arbiter"].state


def seconds(s: float) -> int:
    return round(s * 1e9 / PERIOD_NS)


CALM = DogState()


def test_the_catalogue_has_the_arbiter_and_twelve_behaviors_in_priority_order() -> None:
    assert list(system().behaviors) == [
        "arbiter",
        "get_up",
        "remote",
        "escape",
        "chin",
        "head_pat",
        "back_touch",
        "recharge",
        "sleep",
        "avoid",
        "wall_follow",
        "wander",
        "emotion",
    ]
    assert set(CHANGES) == set(system().behaviors) - {"arbiter"}


def test_nothing_happening_means_wandering() -> None:
    run = Run()
    outputs = run.feed(CALM, seconds(1))
    assert run.winner() == "wander"
    assert outputs["motion"] == "walk"
    assert outputs["speed"] == Tuning().wander_speed
    assert run.state("wander") in ("straight", "veering")


def test_a_fall_is_confirmed_then_the_dog_gets_up() -> None:
    run = Run()
    run.feed(DogState(tilt=95.0), seconds(0.2))
    assert run.state("get_up") == "upright"
    outputs = run.feed(DogState(tilt=95.0), seconds(0.2))
    assert run.state("get_up") == "getting_up"
    assert outputs["motion"] == "getup"
    run.feed(DogState(tilt=5.0), seconds(0.4))
    assert run.state("get_up") == "getting_up"
    cycles = 0
    while run.state("get_up") == "getting_up":
        outputs = run.feed(DogState(tilt=5.0))
        cycles += 1
    assert outputs["motion"] == "stand"  # once, as it hands back control
    assert cycles <= seconds(0.2)


def test_remote_commands_drive_the_dog_until_released_or_silent() -> None:
    run = Run()
    for seq in range(1, 4):
        state = DogState(remote_seq=seq, remote_active=True, remote_speed=0.2, remote_turn=0.5)
        outputs = run.feed(state, 3)
    assert run.winner() == "remote"
    assert (outputs["speed"], outputs["turn"]) == (0.2, 0.5)
    run.feed(DogState(remote_seq=4, remote_active=False))
    assert run.state("remote") == "off"
    run.feed(DogState(remote_seq=5, remote_active=True, remote_speed=0.1))
    assert run.state("remote") == "driving"
    run.feed(DogState(remote_seq=5, remote_active=True, remote_speed=0.1), seconds(1.1))
    assert run.state("remote") == "off"


def _escape_sequence(run: Run, trigger: DogState, cycles: int) -> None:
    run.feed(trigger, cycles)
    assert run.state("escape") == "backing"
    assert run.outputs["speed"] < 0
    run.feed(CALM, seconds(1.05))
    assert run.state("escape") == "turning"
    assert run.outputs["speed"] == 0.0
    assert abs(run.outputs["turn"]) == 1.0
    run.feed(CALM, seconds(1.7))
    assert run.state("escape") == "idle"


def test_a_bump_on_the_nose_makes_the_dog_back_up_and_turn() -> None:
    _escape_sequence(Run(), DogState(bumped=True), 1)


def test_walking_without_moving_for_two_seconds_is_being_stuck() -> None:
    run = Run()
    held = DogState(motion="walk", walk_speed=0.18, speed=0.0)
    run.feed(held, seconds(1.9))
    assert run.state("escape") == "idle"
    _escape_sequence(run, held, seconds(0.2))


def test_a_chin_touch_shakes_the_head_left_and_right() -> None:
    run = Run()
    turns = set()
    run.feed(DogState(touch_chin=True))
    for _ in range(seconds(1.1)):
        turns.add(run.feed(DogState(touch_chin=True))["turn"])
    assert run.state("chin") == "shaking"
    assert turns == {1.5, -1.5}
    run.feed(CALM, seconds(0.2))
    assert run.state("chin") == "idle"


def test_a_head_pat_makes_the_dog_sit_for_two_to_four_seconds() -> None:
    run = Run()
    assert run.feed(DogState(touch_head=True))["motion"] == "sit"
    run.feed(CALM, seconds(1.9))
    assert run.state("head_pat") == "sitting"
    run.feed(CALM, seconds(2.2))
    assert run.state("head_pat") == "idle"


def test_a_held_touch_starts_one_response_not_one_after_another() -> None:
    run = Run()
    run.feed(DogState(touch_back=True), seconds(3.5))
    assert run.state("back_touch") == "idle"


def test_stroking_the_back_makes_the_dog_lie_down_for_three_seconds() -> None:
    run = Run()
    assert run.feed(DogState(touch_back=True))["motion"] == "lie"
    run.feed(CALM, seconds(2.9))
    assert run.state("back_touch") == "lying"
    run.feed(CALM, seconds(0.2))
    assert run.state("back_touch") == "idle"


def test_a_low_battery_sends_the_dog_to_the_pad_to_charge() -> None:
    run = Run()
    outputs = run.feed(DogState(battery=15.0, beacon_bearing=1.0, beacon_distance=2.0))
    assert run.state("recharge") == "seeking"
    assert outputs["speed"] == 0.0
    assert outputs["turn"] == 1.0
    outputs = run.feed(DogState(battery=15.0, beacon_bearing=0.1, beacon_distance=1.0))
    assert outputs["speed"] > 0
    assert run.winner() == "recharge"
    run.feed(DogState(battery=15.0, beacon_distance=1.0, range_front=0.2))
    assert run.winner() == "avoid"
    assert run.feed(DogState(battery=15.0, beacon_distance=0.1))["motion"] == "lie"
    assert run.state("recharge") == "docked"
    run.feed(DogState(battery=50.0, beacon_distance=0.1, charging=True))
    assert run.state("recharge") == "charging"
    run.feed(DogState(battery=95.0, charging=True))
    assert run.state("recharge") == "ok"


def test_boredom_puts_the_dog_to_sleep_and_a_touch_wakes_it() -> None:
    run = Run()
    assert run.feed(DogState(boredom=85))["motion"] == "lie"
    assert run.state("sleep") == "lying_down"
    run.feed(DogState(boredom=85, knee_mean=-2.15))
    assert run.state("sleep") == "asleep"
    run.feed(DogState(boredom=85, touch_back=True))
    assert run.state("sleep") == "awake"
    run.feed(DogState(boredom=85, knee_mean=-2.15), 2)
    assert run.state("sleep") == "asleep"
    run.feed(DogState(boredom=15))
    assert run.state("sleep") == "awake"


@pytest.mark.parametrize(
    ("left", "right", "state", "turn"),
    [(0.3, 1.5, "turning_right", -0.9), (1.5, 0.3, "turning_left", 0.9)],
)
def test_an_obstacle_ahead_turns_the_dog_away_from_the_nearer_side(
    left: float, right: float, state: str, turn: float
) -> None:
    run = Run()
    outputs = run.feed(DogState(range_front=0.3, range_left=left, range_right=right))
    assert run.state("avoid") == state
    assert outputs["turn"] == turn
    run.feed(DogState(range_front=0.5, range_left=left, range_right=right))
    assert run.state("avoid") == state
    run.feed(CALM)
    assert run.state("avoid") == "clear"


def test_a_wall_alongside_is_followed_at_a_steady_distance() -> None:
    run = Run()
    too_far = run.feed(DogState(range_left=0.45, nearest=0.45))
    assert run.state("wall_follow") == "following_left"
    assert too_far["turn"] > 0
    too_near = run.feed(DogState(range_left=0.2, nearest=0.2))
    assert too_near["turn"] < 0
    run.feed(DogState(range_left=1.2))
    assert run.state("wall_follow") == "off"
    run.feed(DogState(range_right=0.3), seconds(4.0))
    assert run.state("wall_follow") == "off"  # resting before following again
    run.feed(DogState(range_right=0.3), seconds(1.2))
    assert run.state("wall_follow") == "following_right"


def _emotions(run: Run, states: Iterable[DogState]) -> list[tuple[int, int]]:
    levels = []
    for state in states:
        outputs = run.feed(state)
        levels.append((outputs["happiness"], outputs["boredom"]))
    return levels


def test_idleness_bores_the_dog_and_a_pat_cheers_it() -> None:
    run = Run()
    levels = _emotions(run, [CALM] * seconds(30))
    assert levels[-1][1] == pytest.approx(45, abs=1)
    assert run.state("emotion") == "content"
    happiness, boredom = _emotions(run, [DogState(touch_head=True)])[0]
    assert boredom < levels[-1][1] - 30
    assert happiness > levels[-1][0] + 15


def test_happiness_fluctuates_with_one_random_draw_a_second() -> None:
    run = Run()
    emotion = list(run.system.behaviors).index("emotion")
    draws = []
    for _ in range(seconds(10)):
        run.feed(CALM)
        draws += [draw for draw in run.random.take() if draw.actor == emotion]
    assert len(draws) == 9  # at 1 s, 2 s, ... 9 s of the 9.99 s fed
    assert {draw.kind for draw in draws} == {"gauss"}

"""Scenario scripts: twenty test cases, each a set-up and a tester's script in words."""

from __future__ import annotations

import pytest

from beatlog_examples.dog.scenarios import DEMO, SUITE, Event, apply, describe, scenario
from beatlog_examples.dog.world import DogWorld


def test_the_suite_has_twenty_cases_of_thirty_seconds_to_three_minutes() -> None:
    assert len(SUITE) == 20
    assert len({s.name for s in SUITE}) == 20
    assert all(30.0 <= s.duration_s <= 180.0 for s in SUITE)
    tags = {tag for s in SUITE for tag in s.tags}
    wanted = {"locomotion", "obstacles", "touch", "remote", "falls", "battery", "boredom"}
    assert wanted <= tags


def test_every_event_can_be_told_in_words_and_happens_within_its_session() -> None:
    for case in (*SUITE, DEMO):
        for event in case.events:
            assert describe(event)
            assert 0 < event.at_s < case.duration_s


def test_the_procedure_tells_the_set_up_and_every_step() -> None:
    steps = scenario("low-battery").procedure()
    assert steps[0] == "Put the dog at (1.6, 2.6) m facing 86°, battery 21%."
    steps = scenario("remote-drive").procedure()
    assert steps[2].startswith("At 3 s: drive it with the remote control for 4 s")


def test_a_box_placed_ahead_lands_in_front_of_the_dog() -> None:
    world = DogWorld(x=1.0, y=1.0, heading=1.5707963)
    apply(world, Event(0.0, "place_ahead", ("box2", 0.8)))
    box = world.data.mocap_pos[world.model.body("box2").mocapid[0]]
    assert box[:2] == pytest.approx((1.0, 1.8), abs=1e-6)


def test_a_light_touch_a_tip_and_a_dropped_link_are_told_in_words() -> None:
    assert describe(Event(1.0, "touch", ("chin", 1.0, 0.0004))) == (
        "touch its chin, pressing 0.4 mm deep, for 1 s"
    )
    assert describe(Event(1.0, "lean", (-1, 63.0, 3.0))) == (
        "tip it 63° to its right for 3 s, then set it upright"
    )
    assert describe(Event(1.0, "drive_dropped", (0.2, 0.0, 3.0))).endswith(
        "then let the link drop without a release"
    )


@pytest.mark.parametrize("action", ["drive", "drive_dropped"])
def test_driving_is_not_an_action_on_the_world(action: str) -> None:
    with pytest.raises(ValueError, match=f"'{action}' is not an action on the world"):
        apply(DogWorld(), Event(1.0, action, (0.1, 0.0, 1.0)))


def test_an_unknown_scenario_names_the_known_ones() -> None:
    with pytest.raises(KeyError, match="walk-straight"):
        scenario("fetch")
